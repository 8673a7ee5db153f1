"""MAVExplorer's graph definitions (MAVProxy's mavgraphs XML) checked
against a DataFlash log, the way MAVExplorer decides which graphs to
offer: a graph shows when one of its expressions evaluates on the log's
messages (pymavlink's `mavutil.evaluate_expression`, with mavextra's
functions such as `diff`, `delta`, `radians`)."""

import importlib.resources
import math
import re
import xml.etree.ElementTree as ET

from pymavlink import DFReader, mavextra, mavutil

# The graphs a Rover log should offer, and their fields' units as ArduPilot
# declares them (FMTU): a plot must mean the same thing for both.
ROVER_GRAPHS = [
    "Speed/Ground Speed",
    "Attitude/Roll and Pitch",
    "Attitude/Attitude Control",
    "Attitude/Circular Angle",
    "Sensors/GPS/GPS Vel NE",
    "Sensors/GPS/GPS Time Jitter",
    "Sensors/GPS/Alt VZ Consistency",
    "Rover/Steering Control",
    "Rover/Speed Control",
    "Rover/Speed and Throttle",
    "Rover/Speed and Battery",
    "Battery",
]
ARDUPILOT_UNITS = {
    ("GPS", "Alt"): "m", ("GPS", "Spd"): "m/s", ("GPS", "GCrs"): "degheading",
    ("GPS", "VZ"): "m/s",
    ("ATT", "Roll"): "deg", ("ATT", "Pitch"): "deg", ("ATT", "DesRoll"): "deg", ("ATT", "DesPitch"): "deg",
    ("STER", "DesTurnRate"): "deg/s", ("STER", "TurnRate"): "deg/s",
    ("STER", "DesLatAcc"): "m/s/s", ("STER", "LatAcc"): "m/s/s",
    ("THR", "DesSpeed"): "m/s", ("THR", "Speed"): "m/s",
    ("BAT", "Volt"): "V", ("BAT", "VoltR"): "V", ("BAT", "Curr"): "A", ("BAT", "CurrTot"): "Ah",
}
FIELD = re.compile(r"\b([A-Z][A-Z0-9_]*)(?:\[\d+\])?\.([A-Za-z_][A-Za-z0-9_]*)")


def load_graphs():
    """{graph name: [expression alternatives]} from MAVProxy's XML files."""
    graphs = {}
    folder = importlib.resources.files("MAVProxy.tools.graphs")
    for name in ("mavgraphs.xml", "mavgraphs2.xml"):
        root = ET.fromstring(folder.joinpath(name).read_text())
        for g in root.findall("graph"):
            exprs = [" ".join(e.text.split()) for e in g.findall("expression") if e.text]
            graphs.setdefault(g.get("name"), []).extend(exprs)
    return graphs


def terms(expression):
    """An expression's plotted terms, without MAVExplorer's axis suffix."""
    out = []
    for term in expression.split():
        if len(term) >= 2 and term[-2] == ":" and term[-1] in "23456789":
            term = term[:-2]
        out.append(term)
    return out


def evaluates(expression, msgs):
    """MAVExplorer's test for offering an expression: every term is a number."""
    for term in terms(expression):
        try:
            value = mavutil.evaluate_expression(term, msgs)
        except Exception:
            return False
        if value is None:
            return False
    return True


def read_log(path):
    """(every message in order, the last of each type as MAVExplorer keeps them)."""
    log = DFReader.DFReader_binary(str(path), zero_time_base=True)
    messages = []
    while (m := log.recv_msg()) is not None:
        messages.append(m)
    return log, messages


def check(path):
    """Asserts that every Rover graph is offered and plots finite values all
    along the log, with ArduPilot's units; returns the graphs offered."""
    log, messages = read_log(path)
    graphs = load_graphs()
    offered = {name: next((e for e in exprs if evaluates(e, log.messages)), None)
               for name, exprs in graphs.items()}
    for name in ROVER_GRAPHS:
        expression = offered.get(name)
        assert expression is not None, f"MAVExplorer would not offer {name!r}: {graphs.get(name)}"
        fields = FIELD.findall(expression)
        assert fields, expression
        for msg_type, field in fields:
            fmt = log.formats[log.name_to_id[msg_type]]
            assert field in fmt.columns, f"{name}: {msg_type}.{field} not in {fmt.columns}"
            unit = fmt.units[fmt.colhash[field]] if fmt.units else None
            want = ARDUPILOT_UNITS.get((msg_type, field))
            assert want is None or unit == want, f"{msg_type}.{field} in {unit!r}, ArduPilot has {want!r}"
        plotted = plot(expression, messages)
        assert len(plotted) > 10, f"{name}: {len(plotted)} points"
        assert all(math.isfinite(v) for v in plotted), f"{name}: not finite"
    return sorted(n for n, e in offered.items() if e is not None)


def plot(expression, messages):
    """The values MAVExplorer would plot: each term evaluated whenever a
    message it reads arrives (as its grapher does)."""
    mavextra.first_fix = None
    types = {t for t, _ in FIELD.findall(expression)}
    msgs, values = {}, []
    for m in messages:
        t = m.get_type()
        msgs[t] = m
        if t not in types:
            continue
        for term in terms(expression):
            try:
                v = mavutil.evaluate_expression(term, msgs)
            except Exception:
                v = None
            if isinstance(v, (int, float)):
                values.append(float(v))
    return values
