"""Parameters: the one table every tunable lives in (definitions, the table, ArduSub's own parameter names).

As ArduPilot's AP_Param: it imports nothing else of the vehicle.
"""
