"""Forecast: the wave forecast's way in — the lock-free hand-off to the control task and its zenoh subscriber.

It imports bridge's forecast codec, the parameter table and the modes' severities; never the laws or MAVLink.
"""
