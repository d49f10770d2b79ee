"""The parameter protocol against a live vehicle, over real UDP with a pymavlink ground station."""
from __future__ import annotations

import math
import os
import time

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import ardupilotmega as mavlink

TYPES = {"REAL32": mavlink.MAV_PARAM_TYPE_REAL32, "INT8": mavlink.MAV_PARAM_TYPE_INT8,
         "INT16": mavlink.MAV_PARAM_TYPE_INT16, "INT32": mavlink.MAV_PARAM_TYPE_INT32}

# fixtures, one live vehicle per module

# --------------------------------------------------------------------------- parameters

def test_parameter_protocol(v):
    gs = v.gs
    params = v.fw.params
    gs.drain()
    gs.send(mavlink.MAVLink_param_request_list_message(1, 1))
    got, end = {}, time.monotonic() + 10
    while len(got) < len(params) and time.monotonic() < end:
        m = gs.wait_type("PARAM_VALUE", timeout=1.0)
        if m is not None:
            assert m.param_count == len(params) and m.param_type == TYPES[params.definition(m.param_id).ptype]
            got[m.param_index] = (m.param_id, m.param_value)
    assert sorted(got) == list(range(len(params)))
    assert [got[i][0] for i in range(len(params))] == params.names()
    assert got[params.index_of("MAV_GCS_SYSID")][1] == 255
    # Read by name and by index
    m = gs.param("WK_PD_KP_X")
    assert m.param_value == pytest.approx(params["WK_PD_KP_X"]) and m.param_index == params.index_of("WK_PD_KP_X")
    gs.drain()
    gs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"", 3))
    m = gs.wait_type("PARAM_VALUE")
    assert (m.param_id, m.param_index) == (params.by_index(3)[0], 3)
    # Set: accepted → the new value comes back
    assert gs.set_param("WK_FF_GAIN", 0.5).param_value == pytest.approx(0.5) and params["WK_FF_GAIN"] == 0.5
    # Out of range, NaN, not an integer: refused, the old value re-sent, and said why
    for bad in (99.0, math.nan, math.inf):
        since = gs.mark()
        assert gs.set_param("WK_FF_GAIN", bad).param_value == pytest.approx(0.5)
        assert gs.wait_type("STATUSTEXT", lambda m: m.text.startswith("WK_FF_GAIN not set"), 2, since) is not None
    assert gs.set_param("FS_GCS_ENABLE", 1.5).param_value == params["FS_GCS_ENABLE"] == 1   # AP_Param truncates
    assert params["WK_FF_GAIN"] == 0.5
    # Unknown names are ignored (nothing comes back) and counted
    before = v.link.counters["rx_ignored"]
    assert gs.set_param("NO_SUCH_PARAM", 1.0, timeout=1.0) is None
    assert gs.param("NO_SUCH_PARAM", timeout=0.5) is None
    assert v.link.counters["rx_ignored"] == before + 2


def test_parameter_types_are_ardusubs_and_set_converts_like_ap_param(v):
    """Integer parameters travel as INT8/INT16 (ArduSub's AP_Int8/AP_Int16), floats as REAL32; PARAM_SET of a
    fraction to an integer parameter is truncated after adding 0.01 towards its sign (AP_Param::set_float)."""
    gs, params = v.gs, v.fw.params
    expected = {"MAV_SYSID": mavlink.MAV_PARAM_TYPE_INT16, "MAV_GCS_SYSID": mavlink.MAV_PARAM_TYPE_INT16,
                "MAV1_EXTRA1": mavlink.MAV_PARAM_TYPE_INT16, "FS_GCS_ENABLE": mavlink.MAV_PARAM_TYPE_INT8,
                "FS_EKF_ACTION": mavlink.MAV_PARAM_TYPE_INT8, "WK_FF_ENABLE": mavlink.MAV_PARAM_TYPE_INT8,
                "WK_FF_GAIN": mavlink.MAV_PARAM_TYPE_REAL32, "FS_GCS_TIMEOUT": mavlink.MAV_PARAM_TYPE_REAL32}
    for name, mav_type in expected.items():
        m = gs.param(name)
        assert m is not None and m.param_type == mav_type, name
        assert m.param_value == params[name]
    # The sender's type is ignored; the value is converted to the parameter's
    for sent, stored in ((3.5, 3), (2.999, 3), (4.0, 4), (0.2, 0)):
        m = gs.set_param("FS_GCS_ENABLE", sent)
        assert (m.param_value, m.param_type) == (stored, mavlink.MAV_PARAM_TYPE_INT8)
        assert params["FS_GCS_ENABLE"] == stored
    assert gs.set_param("MAV1_EXTRA3", 4.7).param_value == 4 and params["MAV1_EXTRA3"] == 4.0
    # Beyond the type (clamped to 127) and beyond the range, or NaN: refused, the value in force re-sent
    for bad in (1e9, -7.0, math.nan):
        since = gs.mark()
        assert gs.set_param("FS_GCS_ENABLE", bad).param_value == 0
        assert gs.wait_type("STATUSTEXT", lambda m: m.text.startswith("FS_GCS_ENABLE not set"), 2, since) is not None
    # Floats keep their fraction
    assert gs.set_param("WK_FF_GAIN", 0.35).param_value == pytest.approx(0.35) and params["WK_FF_GAIN"] == 0.35


def test_ardusubs_parameters_are_served_with_ardusubs_types_and_defaults():
    """Every parameter of ArduSub 4.7's table (configs/firmware/ardusub_params.csv, read from the real binary)
    is in the table with ArduSub's type, and with ArduSub's default unless docs/mavlink.md says why not
    (the ``param.value.NAME`` entries of tests/conformance_differences.py); the 4.7 names, not the old ones."""
    from conformance_differences import DIFFERENCES

    from firmware_py.params.ardusub import reference_table
    from firmware_py.params.table import load_params

    params = load_params()
    wrong = {}
    for name, value, ptype in reference_table():
        if name not in params:
            wrong[name] = "missing"
        elif params.definition(name).ptype != ptype:
            wrong[name] = f"type {params.definition(name).ptype}, ArduSub's {ptype}"
        elif not math.isclose(params[name], value, rel_tol=1e-6, abs_tol=1e-6) and \
                f"param.value.{name}" not in DIFFERENCES:
            wrong[name] = f"{params[name]!r}, ArduSub's {value!r}"
    assert not wrong, wrong
    assert params["MAV_GCS_SYSID"] == 255 and params["FS_PILOT_INPUT"] == 2 and params["ARMING_CHECK"] == 448
    assert not {"SYSID_MYGCS", "SYSID_THISMAV", "SR0_EXTRA1", "JS_LIGHTS_STEP"} & set(params.names())
