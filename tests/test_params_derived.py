"""ParameterTable.derived: a value computed from the table is kept until a parameter changes."""
from __future__ import annotations

from firmware_py.params.table import load_params


def test_derived_values_are_kept_until_a_parameter_changes():
    p = load_params()
    calls = []

    def gains(table):
        calls.append(table.version)
        return table["WK_PD_KP_X"] * 2.0

    first = p.derived(gains)
    assert p.derived(gains) == first and len(calls) == 1          # asked again: not recomputed
    assert p.set("WK_PD_KP_X", p["WK_PD_KP_X"]) is None           # the same value: no change
    assert p.derived(gains) == first and len(calls) == 1
    assert p.set("WK_PD_KP_X", p["WK_PD_KP_X"] + 0.1) is None
    assert p.derived(gains) == (first / 2.0 + 0.1) * 2.0 and len(calls) == 2
    assert p.set("WK_PD_KP_X", -1e9) is not None                 # refused: nothing moves
    p.derived(gains)
    assert len(calls) == 2
    # a copy is another table, with its own values and derived values
    q = p.copy()
    q.set("WK_PD_KP_X", q["WK_PD_KP_X"] + 0.1)
    assert q.derived(gains) != p.derived(gains) and len(calls) == 3


def test_each_owner_keeps_its_own_derived_value():
    p = load_params()

    class Owner:
        def __init__(self, k):
            self.k = k

        def read(self, table):
            return table["WK_PD_KP_X"] * self.k

    a, b = Owner(1.0), Owner(3.0)
    assert p.derived(b.read) == 3.0 * p.derived(a.read)
