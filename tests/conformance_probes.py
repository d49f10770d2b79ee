"""What the conformance suite asks a vehicle, and how (:mod:`test_ardusub_conformance`): pymavlink helpers
that work the same on the real ArduSub and on Wavekeep, in vehicle time."""
from __future__ import annotations

import csv
import itertools
import re
import time

from ardusub_pair import ROOT, Vehicle
from pymavlink.dialects.v20 import ardupilotmega as mavlink

M = mavlink
MODE_NAMES = {0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 7: "CIRCLE", 9: "SURFACE",
              16: "POSHOLD", 19: "MANUAL", 20: "MOTOR_DETECT", 21: "SURFTRAK", 99: "99"}
NOISE = re.compile(r"^(EKF3 |AHRS: |GPS \d|Barometer \d|Calibrating barometer|RCInput|Field Elevation)")
"""STATUSTEXTs of ArduSub's estimator, GPS driver and boot chatter: not what a test asked about."""
REFERENCE = ROOT / "configs" / "firmware" / "ardusub_params.csv"


def texts(msgs, noise: bool = False) -> list[list]:
    """[severity, text] of each STATUSTEXT (ArduSub's estimator and GPS chatter left out)."""
    return [[m.severity, m.text] for m in msgs if m.get_type() == "STATUSTEXT" and (noise or not NOISE.match(m.text))]


def heartbeat(v: Vehicle, pred=lambda m: True, sim_s: float = 2.0):
    return v.gs.heartbeat(pred, timeout=v.wall(sim_s))


def command(v: Vehicle, cmd: int, *params: float, sim_s: float = 2.0):
    """COMMAND_LONG; (ACK result or None, every message heard until the ACK and 0.5 s of vehicle time after)."""
    since = v.gs.mark()
    ack = v.gs.command(cmd, *params, timeout=v.wall(sim_s))
    v.wait(0.5)
    return (None if ack is None else int(ack.result)), v.gs.log[since:]


def read_params(v: Vehicle, names, sim_s: float = 3.0) -> dict[str, list | None]:
    """PARAM_REQUEST_READ by name of each; [value, MAV_PARAM_TYPE] or None (no answer)."""
    gs = v.gs
    got: dict[str, list | None] = {}
    for _attempt in range(2):
        since = gs.mark()
        for n in names:
            if n not in got:
                gs.send(M.MAVLink_param_request_read_message(1, 1, n.encode(), -1))
        end = time.monotonic() + v.wall(sim_s)
        while time.monotonic() < end and len(got) < len(names):
            gs._pump(0.1)
            for m in gs.log[since:]:
                if m.get_type() == "PARAM_VALUE" and m.param_id in names:
                    got[m.param_id] = [float(m.param_value), int(m.param_type)]
            since = len(gs.log)
    return {n: got.get(n) for n in names}


def set_mode(v: Vehicle, mode: int) -> dict:
    """SET_MODE (base_mode CUSTOM_MODE_ENABLED): the mode in the next heartbeat, what was said, any COMMAND_ACK."""
    since = v.gs.mark()
    v.gs.send(M.MAVLink_set_mode_message(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode))
    msgs = v.wait(1.5)
    hb = [m for m in msgs if m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1]
    hb = hb[-1] if hb else heartbeat(v)
    return {"mode": MODE_NAMES.get(hb.custom_mode, hb.custom_mode), "texts": texts(v.gs.log[since:]),
            "acked": any(m.get_type() == "COMMAND_ACK" for m in v.gs.log[since:])}


def wait_position(v: Vehicle) -> bool:
    """Until the EKF reports an absolute horizontal position (ArduSub: its GPS; Wavekeep: the position fix)."""
    return v.gs.wait_type("EKF_STATUS_REPORT", lambda m: m.flags & M.EKF_POS_HORIZ_ABS
                          and m.flags & M.EKF_PRED_POS_HORIZ_ABS, timeout=v.wall(90.0)) is not None


def to_manual(v: Vehicle) -> None:
    v.gs.send(M.MAVLink_set_mode_message(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 19))
    heartbeat(v, lambda m: m.custom_mode == 19)


def disarm(v: Vehicle) -> None:
    v.gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0, timeout=v.wall(2.0))
    heartbeat(v, lambda m: not m.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)


def reference_table() -> dict[str, tuple[float, str]]:
    """configs/firmware/ardusub_params.csv: ArduSub's table, read from the binary (its header says how)."""
    with REFERENCE.open() as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    return {r["name"]: (float(r["value"]), r["type"]) for r in rows}


def bits(prefix: str) -> dict[int, str]:
    return {getattr(M, n): n[len(prefix):] for n in dir(M) if n.startswith(prefix) and not n.endswith("ENUM_END")}


def lost(msgs) -> int:
    """Messages the ground station missed in a run of the vehicle's (gaps in their MAVLink sequence numbers)."""
    seqs = [m.get_seq() for m in msgs]
    return sum((b - a - 1) % 256 for a, b in itertools.pairwise(seqs))


def listen(v: Vehicle, sim_s: float) -> list:
    """The autopilot's messages over ``sim_s`` of vehicle time, heard again (up to 3 times) if the ground
    station lost more than 1 % of them: a loaded machine may drop datagrams, which would read as a low rate."""
    for _attempt in range(3):
        msgs = [m for m in v.wait(sim_s) if m.get_srcSystem() == 1 and m.get_srcComponent() == 1]
        if lost(msgs) <= len(msgs) // 100:
            break
    return msgs


