"""VDA 5050 2.1 against a real Mosquitto broker: a master control written
with paho-mqtt sends orders and instant actions to `furrow sitl --vda5050`
and reads the vehicle's state, connection and factsheet."""

import json
import math
import pathlib
import queue
import shutil
import signal
import socket
import subprocess
import time

import pytest

paho = pytest.importorskip("paho.mqtt.client")

MOSQUITTO = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
SERIAL = "T1"
PREFIX = f"uagv/v2/Furrow/{SERIAL}"


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Broker:
    """Mosquitto on a loopback port, anonymous, no persistence; it can be
    killed and started again on the same port."""

    def __init__(self, tmp_path):
        if not pathlib.Path(MOSQUITTO).exists():
            pytest.fail("mosquitto is not installed (tests/run installs it)")
        self.port = free_port()
        self.conf = tmp_path / "mosquitto.conf"
        self.conf.write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\npersistence false\n")
        self.log = open(tmp_path / "mosquitto.log", "a")
        self.proc = None
        self.start()

    def start(self):
        self.proc = subprocess.Popen([MOSQUITTO, "-c", str(self.conf)], stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                return
            except OSError:
                time.sleep(0.05)
        self.proc.kill()
        pytest.fail("mosquitto did not start")

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(timeout=10)


@pytest.fixture
def mosquitto(tmp_path):
    b = Broker(tmp_path)
    yield b
    b.stop()
    b.log.close()


@pytest.fixture
def broker(mosquitto):
    return mosquitto.port


class Master:
    """The master control's side: publishes to the vehicle, keeps what it
    publishes by topic."""

    def __init__(self, port):
        self.messages = queue.Queue()
        self.states = []
        self.connections = []
        self.factsheets = []
        self.header_id = 0
        self.client = paho.Client(paho.CallbackAPIVersion.VERSION2, client_id="master")
        self.client.on_message = lambda _c, _u, m: self.messages.put((m.topic, m.payload))
        # Subscribed on every connect: a restarted broker has forgotten us.
        self.client.on_connect = lambda c, _u, _f, _r, _p: c.subscribe(f"{PREFIX}/#", qos=1)
        self.client.reconnect_delay_set(0.2, 1)
        self.client.connect("127.0.0.1", port)
        self.client.loop_start()

    def close(self):
        self.client.loop_stop()
        self.client.disconnect()

    def pump(self, timeout=0.1):
        try:
            topic, payload = self.messages.get(timeout=timeout)
        except queue.Empty:
            return
        name = topic.rsplit("/", 1)[1]
        if name in ("order", "instantActions"):
            return  # our own
        body = json.loads(payload)
        {"state": self.states, "connection": self.connections, "factsheet": self.factsheets}.get(name, []).append(body)

    def wait(self, what, predicate, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.pump()
            if predicate(self):
                return
        last = self.states[-1] if self.states else None
        raise AssertionError(f"timed out waiting for {what}; last state: {json.dumps(last)[:3000]}")

    def header(self):
        self.header_id += 1
        return {
            "headerId": self.header_id,
            "timestamp": "2026-11-27T05:00:00.00Z",
            "version": "2.1.0",
            "manufacturer": "Furrow",
            "serialNumber": SERIAL,
        }

    def publish(self, topic, body):
        payload = body if isinstance(body, bytes) else json.dumps(body)
        self.client.publish(f"{PREFIX}/{topic}", payload, qos=0).wait_for_publish(5)

    def instant(self, action_id, kind):
        self.publish("instantActions", {**self.header(), "actions": [
            {"actionId": action_id, "actionType": kind, "blockingType": "NONE"}]})

    def last(self):
        return self.states[-1]

    def nodes_reported(self):
        ids = []
        for s in self.states:
            if s["lastNodeId"] and (not ids or ids[-1] != s["lastNodeId"]):
                ids.append(s["lastNodeId"])
        return ids

    def action(self, action_id):
        for a in self.last()["actionStates"]:
            if a["actionId"] == action_id:
                return a["actionStatus"]
        return None


def order(master, origin, order_id, nodes, reverse=()):
    """nodes: (id, dx, dy, action or None), relative to origin (map x, y)."""
    ox, oy = origin
    node_list, edge_list = [], []
    for i, (nid, dx, dy, action) in enumerate(nodes):
        actions = [{"actionId": action[0], "actionType": action[1], "blockingType": "HARD"}] if action else []
        node_list.append({"nodeId": nid, "sequenceId": 2 * i, "released": True, "actions": actions,
                          "nodePosition": {"x": ox + dx, "y": oy + dy, "mapId": "yard",
                                           "allowedDeviationXY": 0.25}})
        if i > 0:
            edge = {"edgeId": f"e{2 * i - 1}", "sequenceId": 2 * i - 1, "released": True,
                    "startNodeId": nodes[i - 1][0], "endNodeId": nid, "maxSpeed": 1.5, "actions": []}
            if i - 1 in reverse:
                edge["orientation"] = math.pi
                edge["orientationType"] = "TANGENTIAL"
            edge_list.append(edge)
    return {**master.header(), "orderId": order_id, "orderUpdateId": 0, "nodes": node_list, "edges": edge_list}


@pytest.fixture
def fleet(broker, start_sitl):
    """A vehicle on the broker, localised, and a master control."""
    master = Master(broker)
    # State is paced on the wall clock (1 Hz while driving): at speedup 3
    # the 8 m reverse edge spans a few states.
    sitl = start_sitl(speedup="3", extra_args=[
        "--vda5050", f"mqtt://127.0.0.1:{broker}", "--serial-number", SERIAL, "--map-id", "yard"])
    master.wait("ONLINE", lambda m: any(c["connectionState"] == "ONLINE" for c in m.connections), 15)
    master.wait("a localised state", lambda m: m.states and (m.last().get("agvPosition") or {}).get(
        "positionInitialized") and m.last()["agvPosition"]["localizationScore"] == 1.0, 60)
    # The estimate settles over the first seconds at rest.
    time.sleep(1.0)
    master.instant("s0", "stateRequest")
    master.wait("a fresh state", lambda m: m.action("s0") == "FINISHED", 10)
    position = master.last()["agvPosition"]
    yield master, sitl, (position["x"], position["y"])
    master.close()


def test_an_order_with_a_reverse_edge_and_pick_drop_is_driven_and_every_node_reported(fleet):
    master, sitl, origin = fleet
    assert master.factsheets, "a factsheet is published at connect"
    actions = {a["actionType"] for a in master.factsheets[-1]["protocolFeatures"]["agvActions"]}
    assert {"pick", "drop", "cancelOrder", "startPause"} <= actions
    nodes = [("n0", 0, 0, None), ("n1", 0, 10, None), ("n2", 0, 20, ("pick1", "pick")),
             ("n3", 0, 12, None), ("n4", 0, 25, None), ("n5", 0, 35, ("drop1", "drop"))]
    master.publish("order", order(master, origin, "job1", nodes, reverse=(2,)))
    master.wait("the order to complete", lambda m: m.last()["lastNodeId"] == "n5"
                and not m.last()["nodeStates"] and m.action("drop1") == "FINISHED", 180)
    assert master.nodes_reported() == ["n0", "n1", "n2", "n3", "n4", "n5"]
    assert master.action("pick1") == "FINISHED"
    assert any(s["lastNodeId"] == "n2" and s["velocity"]["vx"] < -0.2 for s in master.states), "no reverse"
    assert master.last()["operatingMode"] == "AUTOMATIC"
    assert sitl.alive()


def test_cancel_mid_edge_stops_and_a_malformed_order_is_rejected_beside_the_running_one(fleet):
    master, sitl, origin = fleet
    master.publish("order", order(master, origin, "job2", [("a", 0, 0, None), ("b", 0, 40, None)]))
    master.wait("driving", lambda m: m.last()["driving"], 30)
    master.publish("order", b"{\"orderId\": ")
    bad = order(master, origin, "job3", [("a", 0, 0, None), ("b", 0, 5, None)])
    bad["edges"] = []
    master.publish("order", bad)
    master.wait("two validation errors", lambda m: [e["errorType"] for e in m.last()["errors"]]
                == ["validationError", "validationError"], 10)
    assert master.last()["orderId"] == "job2" and master.last()["driving"], "the running order goes on"
    master.instant("c1", "cancelOrder")
    master.wait("the cancel to finish", lambda m: m.action("c1") == "FINISHED", 20)
    last = master.last()
    assert not last["driving"] and last["nodeStates"] == [] and last["edgeStates"] == []
    assert last["lastNodeId"] == "a", "cancelled on the edge, short of b"
    assert sitl.alive()


def test_connection_goes_offline_on_a_clean_stop_and_broken_when_killed(broker, start_sitl):
    master = Master(broker)
    sitl = start_sitl(speedup="10", extra_args=[
        "--vda5050", f"mqtt://127.0.0.1:{broker}", "--serial-number", SERIAL, "--map-id", "yard"])
    master.wait("ONLINE", lambda m: m.connections and m.connections[-1]["connectionState"] == "ONLINE", 15)
    assert sitl.stop() == 0
    master.wait("OFFLINE", lambda m: m.connections[-1]["connectionState"] == "OFFLINE", 10)
    sitl = start_sitl(speedup="10", extra_args=[
        "--vda5050", f"mqtt://127.0.0.1:{broker}", "--serial-number", SERIAL, "--map-id", "yard"])
    master.wait("ONLINE again", lambda m: m.connections[-1]["connectionState"] == "ONLINE", 15)
    sitl.proc.send_signal(signal.SIGKILL)
    sitl.proc.wait()
    master.wait("CONNECTIONBROKEN", lambda m: m.connections[-1]["connectionState"] == "CONNECTIONBROKEN", 20)
    master.close()


def test_an_order_carries_on_through_a_broker_restart(fleet, mosquitto):
    master, sitl, origin = fleet
    master.publish("order", order(master, origin, "job4", [("a", 0, 0, None), ("b", 0, 30, None)]))
    master.wait("driving", lambda m: m.last()["driving"], 30)
    onlines = sum(c["connectionState"] == "ONLINE" for c in master.connections)
    mosquitto.stop()
    time.sleep(2.0)
    mosquitto.start()
    master.wait("ONLINE again", lambda m: sum(c["connectionState"] == "ONLINE" for c in m.connections) > onlines, 20)
    master.wait("the order to complete", lambda m: m.last()["lastNodeId"] == "b" and not m.last()["nodeStates"], 60)
    assert master.last()["orderId"] == "job4"
    assert sitl.alive()
