"""Logger: the schema of the firmware's tick log (its columns and the solver status codes), as AP_Logger's structures.

Kept apart so a reader of the log need not import the firmware; it imports nothing of the vehicle.
"""
