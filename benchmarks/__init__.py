"""Wavekeep benchmarks: each writes its figures as JSON with the machine's description."""
