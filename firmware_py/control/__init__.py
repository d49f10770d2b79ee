"""Control: the station-keeping laws behind one interface (C-PD with its FF, DOB and preview terms, the preview MPC).

Holds the laws, their feed-forward, the depth correction and the wrench limits; it may import estimation,
forecast, hal.sensors, params, numerics and logger, never mavlink, the mixer or the vehicle above it.
"""
