"""Contracts shared by the vehicle, the simulator and the shore: config files, schemas, codecs."""
