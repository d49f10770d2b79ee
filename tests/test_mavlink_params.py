"""The parameter protocol against a live vehicle, over real UDP with a pymavlink ground station."""
from __future__ import annotations

import math
import os
import time

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

# fixtures, one live vehicle per module
from mavlink_gcs import _restore, v  # noqa: E402,F401


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
            assert m.param_count == len(params) and m.param_type == mavlink.MAV_PARAM_TYPE_REAL32
            got[m.param_index] = (m.param_id, m.param_value)
    assert sorted(got) == list(range(len(params)))
    assert [got[i][0] for i in range(len(params))] == params.names()
    assert got[params.index_of("SYSID_MYGCS")][1] == 255
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
    assert gs.set_param("FS_GCS_ENABLE", 1.5).param_value == params["FS_GCS_ENABLE"] == 2
    assert params["WK_FF_GAIN"] == 0.5
    # Unknown names are ignored (nothing comes back) and counted
    before = v.link.counters["rx_ignored"]
    assert gs.set_param("NO_SUCH_PARAM", 1.0, timeout=1.0) is None
    assert gs.param("NO_SUCH_PARAM", timeout=0.5) is None
    assert v.link.counters["rx_ignored"] == before + 2
