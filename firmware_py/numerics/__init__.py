"""Numerics: scalar arithmetic with numpy's semantics for the per-tick code (as ArduPilot's AP_Math).

It imports nothing of the vehicle.
"""
