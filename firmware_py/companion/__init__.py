"""Companion mode: the Wavekeep control task on a companion computer, flying a BlueROV2 through ArduSub.

:mod:`.autopilot` talks MAVLink to the autopilot (telemetry, identity, parameters,
stream rates, TIMESYNC); :mod:`.hal_mavlink` is the HAL built on it
(:class:`MAVLinkAutopilotHAL`); :mod:`.commander` turns the mixer's output into
RC_CHANNELS_OVERRIDE (``rc`` or ``servo`` method) and owns the safety rules;
:mod:`.app` is ``wavekeep companion``. See ``docs/companion.md``.
"""
