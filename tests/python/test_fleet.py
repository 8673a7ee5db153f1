"""`furrow sitl --fleet 2` against a real Mosquitto: two AGVs that share one
world are sent head-on at each other down a corridor by VDA 5050 orders, and
both stop short of each other (each sees the other with its scanners)."""

import json
import queue
import re
import signal
import subprocess
import time

import pytest

from conftest import FURROW
from test_vda5050 import Broker

paho = pytest.importorskip("paho.mqtt.client")

READY = re.compile(r"furrow sitl ready: vehicle (\d+): tcp (\S+):(\d+)")
# A 6 m aisle up the line east = 0.
CORRIDOR = """
[[static]]
kind = "wall"
from = [-10.0, -3.0]
to = [60.0, -3.0]
thickness_m = 0.2

[[static]]
kind = "wall"
from = [-10.0, 3.0]
to = [60.0, 3.0]
thickness_m = 0.2
"""
# Nose to nose 40 − 2·3.6 = 32.8 m apart.
HOMES = "# north east heading\n0 0 0\n40 0 180\n"
NOSE_M = 3.6


class Fleet:
    """The fleet process; its ready lines give each vehicle's TCP port."""

    def __init__(self, tmp_path, broker_port, count, speedup):
        (tmp_path / "corridor.toml").write_text(CORRIDOR)
        (tmp_path / "homes.txt").write_text(HOMES)
        self.stderr = open(tmp_path / "fleet.log", "w")
        args = [FURROW, "sitl", "--fleet", str(count), "--fleet-homes", str(tmp_path / "homes.txt"),
                "--world", str(tmp_path / "corridor.toml"), "--data-dir", str(tmp_path / "data"),
                "--tcp-port", "0", "--speedup", str(speedup),
                "--vda5050", f"mqtt://127.0.0.1:{broker_port}", "--serial-number", "F", "--map-id", "yard"]
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=self.stderr, text=True)
        self.tcp_ports = []
        for _ in range(count + 1):
            line = self.proc.stdout.readline()
            match = READY.search(line)
            if match:
                self.tcp_ports.append(int(match.group(3)))
        assert len(self.tcp_ports) == count, f"not every vehicle is ready: {self.tcp_ports}"

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.stderr.close()
        return self.proc.returncode


class Control:
    """A master control for several vehicles: the last state of each."""

    def __init__(self, port):
        self.inbox = queue.Queue()
        self.states = {}
        self.header_id = 0
        self.client = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id="fleet-master")
        self.client.on_message = lambda _c, _u, m: self.inbox.put((m.topic, m.payload))
        self.client.on_connect = lambda c, _u, _f, _r, _p: c.subscribe("uagv/v2/Furrow/+/state", qos=0)
        self.client.connect("127.0.0.1", port)
        self.client.loop_start()

    def close(self):
        self.client.loop_stop()
        self.client.disconnect()

    def wait(self, what, predicate, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                topic, payload = self.inbox.get(timeout=0.1)
                self.states.setdefault(topic.split("/")[3], []).append(json.loads(payload))
            except queue.Empty:
                pass
            if predicate(self):
                return
        last = {serial: s[-1] for serial, s in self.states.items()}
        raise AssertionError(f"timed out waiting for {what}; last states: {json.dumps(last)[:3000]}")

    def last(self, serial):
        return self.states[serial][-1]

    def localised(self, serial):
        states = self.states.get(serial)
        return bool(states) and (states[-1].get("agvPosition") or {}).get("positionInitialized")

    def order(self, serial, order_id, start, end):
        self.header_id += 1
        nodes, edges = [], []
        for i, (node_id, (x, y)) in enumerate([("start", start), ("end", end)]):
            nodes.append({"nodeId": node_id, "sequenceId": 2 * i, "released": True, "actions": [],
                          "nodePosition": {"x": x, "y": y, "mapId": "yard", "allowedDeviationXY": 0.25}})
        edges.append({"edgeId": "e1", "sequenceId": 1, "released": True, "startNodeId": "start",
                      "endNodeId": "end", "maxSpeed": 1.5, "actions": []})
        body = {"headerId": self.header_id, "timestamp": "2026-11-27T08:00:00.00Z", "version": "2.1.0",
                "manufacturer": "Furrow", "serialNumber": serial, "orderId": order_id, "orderUpdateId": 0,
                "nodes": nodes, "edges": edges}
        self.client.publish(f"uagv/v2/Furrow/{serial}/order", json.dumps(body), qos=0).wait_for_publish(5)


@pytest.fixture
def broker(tmp_path):
    b = Broker(tmp_path)
    yield b.port
    b.close()


def test_two_vehicles_meeting_head_on_in_a_corridor_both_stop_short_of_each_other(tmp_path, broker):
    control = Control(broker)
    fleet = Fleet(tmp_path, broker, count=2, speedup=3)
    try:
        serials = ["F-0", "F-1"]
        control.wait("both localised", lambda c: all(c.localised(s) for s in serials), 60)
        time.sleep(1.0)
        control.wait("fresh states", lambda c: all(c.localised(s) for s in serials), 5)
        starts = {s: (control.last(s)["agvPosition"]["x"], control.last(s)["agvPosition"]["y"]) for s in serials}
        # Map y is north: each is sent 40 m on, to where the other stands.
        # The shared map frame: each reports where its home put it.
        for serial, home in zip(serials, ((0.0, 0.0), (0.0, 40.0))):
            assert abs(starts[serial][0] - home[0]) < 0.1 and abs(starts[serial][1] - home[1]) < 0.1, starts
        for serial, north in zip(serials, (40.0, -40.0)):
            x, y = starts[serial]
            control.order(serial, f"through-{serial}", (x, y), (x, y + north))
        control.wait("both driving", lambda c: all(c.last(s)["driving"] for s in serials), 30)

        def both_stopped(c):
            return all(not c.last(s)["driving"] and abs(c.last(s)["velocity"]["vx"]) < 0.05 for s in serials)

        control.wait("both to stop", both_stopped, 120)
        time.sleep(3.0)
        control.wait("still stopped", both_stopped, 5)
        y = {s: control.last(s)["agvPosition"]["y"] for s in serials}
        travelled = {"F-0": y["F-0"] - starts["F-0"][1], "F-1": starts["F-1"][1] - y["F-1"]}
        # One map frame for the fleet (about --home): the gap is where they
        # say they are.
        gap = (y["F-1"] - y["F-0"]) - 2 * NOSE_M
        print(f"travelled {travelled}, gap between noses {gap:.2f} m")
        assert all(d > 3.0 for d in travelled.values()), f"both drove: {travelled}"
        assert 0.1 < gap < 5.0, f"stopped {gap:.2f} m apart"
        for s in serials:
            last = control.last(s)
            assert last["nodeStates"], f"{s} did not reach the other's place: it stopped short"
            assert last["safetyState"]["fieldViolation"], f"{s} says why it stopped"
            assert [e["errorType"] for e in last["errors"]] == ["obstacleStop"], last["errors"]
        assert fleet.proc.poll() is None
    finally:
        control.close()
        assert fleet.stop() == 0
