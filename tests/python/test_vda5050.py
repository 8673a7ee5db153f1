"""VDA 5050 2.1 against a real Mosquitto broker: a master control written
with paho-mqtt sends orders and instant actions to `furrow sitl --vda5050`
and reads the vehicle's state, connection and factsheet."""

import getpass
import json
import math
import pathlib
import queue
import selectors
import shutil
import signal
import socket
import subprocess
import tempfile
import threading
import time

import pytest
from gcs import command, mavlink

paho = pytest.importorskip("paho.mqtt.client")

MOSQUITTO = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
SERIAL = "T1"
PREFIX = f"uagv/v2/Furrow/{SERIAL}"


class BrokerPort:
    """The broker's TCP port, owned by the test: bound to port 0 (the OS picks
    it) and kept for the whole test, while each connection is carried to the
    broker's Unix socket. Mosquitto cannot bind TCP port 0 and say what it
    got, and a broker restarted on a port it had let go could find it taken;
    behind this port it can stop and start again. While no broker is there a
    connection is accepted and closed at once."""

    def __init__(self, unix_path):
        self.unix_path = str(unix_path)
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.listener.settimeout(0.2)
        self.port = self.listener.getsockname()[1]
        self.closed = threading.Event()
        self.accepting = threading.Thread(target=self._accept, daemon=True)
        self.accepting.start()

    def _accept(self):
        while not self.closed.is_set():
            try:
                client, _ = self.listener.accept()
            except (socket.timeout, OSError):
                continue
            client.settimeout(None)
            broker = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                broker.connect(self.unix_path)
            except OSError:
                client.close()
                broker.close()
                continue
            threading.Thread(target=self._carry, args=(client, broker), daemon=True).start()

    def _carry(self, client, broker):
        """Both directions of one connection; when either side ends, both do
        (a broker that stops closes its clients' connections)."""
        with client, broker, selectors.DefaultSelector() as selector:
            selector.register(client, selectors.EVENT_READ, broker)
            selector.register(broker, selectors.EVENT_READ, client)
            while not self.closed.is_set():
                for key, _ in selector.select(timeout=0.2):
                    try:
                        data = key.fileobj.recv(65536)
                        if not data:
                            return
                        key.data.sendall(data)
                    except OSError:
                        return

    def close(self):
        self.closed.set()
        self.accepting.join()
        self.listener.close()


class Broker:
    """Mosquitto, anonymous, no persistence, behind a loopback TCP port the
    test owns; it can be stopped and started again behind the same port."""

    def __init__(self, tmp_path, settings="allow_anonymous true\n"):
        if not pathlib.Path(MOSQUITTO).exists():
            pytest.fail("mosquitto is not installed (tests/run installs it)")
        # A short directory: a Unix socket path has at most 107 bytes.
        self.socket_dir = pathlib.Path(tempfile.mkdtemp(prefix="furrow-mqtt-"))
        self.unix_path = self.socket_dir / "broker.sock"
        self.conf = tmp_path / "mosquitto.conf"
        # Started as root, mosquitto drops to its own user, who cannot
        # create the socket or read the test's files.
        self.conf.write_text(f"listener 0 {self.unix_path}\npersistence false\nuser {getpass.getuser()}\n"
                             f"{settings}")
        self.log = open(tmp_path / "mosquitto.log", "a")
        self.proc = None
        self.start()
        self.tcp = BrokerPort(self.unix_path)
        self.port = self.tcp.port

    def start(self):
        self.proc = subprocess.Popen([MOSQUITTO, "-c", str(self.conf)], stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            try:
                with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as probe:
                    probe.connect(str(self.unix_path))
                return
            except OSError:
                time.sleep(0.05)
        self.proc.kill()
        pytest.fail("mosquitto did not start")

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        self.proc.wait(timeout=10)

    def close(self):
        """The broker, its port and its socket's directory, at the test's end."""
        self.stop()
        self.tcp.close()
        self.log.close()
        shutil.rmtree(self.socket_dir, ignore_errors=True)


@pytest.fixture
def mosquitto(tmp_path):
    b = Broker(tmp_path)
    yield b
    b.close()


@pytest.fixture
def broker(mosquitto):
    return mosquitto.port


class Master:
    """The master control's side: publishes to the vehicle, keeps what it
    publishes by topic."""

    def __init__(self, port, tls=None, user=None):
        """tls: (CA, certificate, key) files; user: (name, password)."""
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
        if tls:
            self.client.tls_set(ca_certs=str(tls[0]), certfile=str(tls[1]), keyfile=str(tls[2]))
        if user:
            self.client.username_pw_set(*user)
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
    # The load is on from the pick's end to the drop's end, and the map is the one configured.
    loaded = [s for s in master.states if s["loads"]]
    assert loaded and loaded[0]["lastNodeId"] == "n2" and loaded[-1]["lastNodeId"] in ("n4", "n5")
    assert master.last()["loads"] == []
    assert master.last()["maps"] == [{"mapId": "yard", "mapVersion": "1", "mapStatus": "ENABLED"}]
    info = {i["infoType"]: i["infoDescription"] for i in master.last()["information"]}
    assert info["mode"] == "AUTO" and info["gnssFix"].startswith("RTK fixed"), info
    assert master.last()["safetyState"] == {"eStop": "NONE", "fieldViolation": False}
    assert master.last()["operatingMode"] == "AUTOMATIC"
    assert sitl.alive()


def quarter_circle(master, origin, order_id, r):
    """a -> b north 8 m, then b -> c a quarter circle of radius r turning
    east (a NURBS: rational quadratic, its degree written as a float)."""
    x0, y0 = origin
    body = order(master, origin, order_id, [("a", 0, 0, None), ("b", 0, 8, None), ("c", r, 8 + r, None)])
    body["edges"][1]["trajectory"] = {
        "degree": 2.0, "knotVector": [0, 0, 0, 1, 1, 1],
        "controlPoints": [{"x": x0, "y": y0 + 8}, {"x": x0, "y": y0 + 8 + r, "weight": math.sqrt(0.5)},
                          {"x": x0 + r, "y": y0 + 8 + r}]}
    return body


def test_an_order_with_a_nurbs_edge_is_driven_on_the_curve_and_a_too_tight_one_refused(fleet):
    master, sitl, origin = fleet
    x0, y0 = origin
    # 4 m is tighter than the simulated car turns (2.9 m wheelbase, 30 degree steering: 5 m).
    master.publish("order", quarter_circle(master, origin, "tight", 4.0))
    master.wait("the refusal", lambda m: [e["errorType"] for e in m.last()["errors"]] == ["orderError"], 10)
    assert "radius" in master.last()["errors"][0]["errorDescription"]
    assert master.last()["orderId"] == "" and not master.last()["driving"]

    master.publish("order", quarter_circle(master, origin, "curve", 8.0))
    master.wait("c reached", lambda m: m.last()["orderId"] == "curve" and m.last()["lastNodeId"] == "c"
                and not m.last()["nodeStates"] and not m.last()["driving"], 120)
    assert master.nodes_reported()[-3:] == ["a", "b", "c"]
    assert master.last()["errors"] == []
    on_curve = [(s["agvPosition"]["x"] - x0, s["agvPosition"]["y"] - y0) for s in master.states
                if s["orderId"] == "curve" and s["lastNodeId"] == "b"]
    on_curve = [(x, y) for x, y in on_curve if 0.5 < x < 7.5 and y > 8.5]
    assert on_curve, "no state from the curve"
    for x, y in on_curve:
        assert abs(math.hypot(x - 8, y - 8) - 8) < 0.3, f"({x:.2f}, {y:.2f}) is off the curve"
    x, y = (master.last()["agvPosition"][k] for k in ("x", "y"))
    assert math.hypot(x - x0 - 8, y - y0 - 16) < 0.3, f"stopped at ({x - x0:.2f}, {y - y0:.2f})"
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


HOLD, AUTO = 4, 10


def set_mode(gcs, mode):
    ack = command(gcs, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)
    assert ack and ack.result == mavlink.MAV_RESULT_ACCEPTED, ack


def test_a_gcs_switching_to_hold_pauses_the_order_and_auto_gives_it_back(fleet):
    """Who is in charge: the master control while the vehicle is in AUTO. A
    ground station switching to HOLD mid-order takes the vehicle: the order
    is kept but paused, `operatingMode` is SERVICE, and nothing fights the
    ground station. Switching back to AUTO gives the vehicle back to the
    master control and the order resumes where it stood."""
    master, sitl, origin = fleet
    master.publish("order", order(master, origin, "job5", [("a", 0, 0, None), ("b", 0, 30, None)]))
    master.wait("driving", lambda m: m.last()["driving"], 30)
    gcs = sitl.tcp()
    set_mode(gcs, HOLD)
    master.wait("SERVICE, paused", lambda m: m.last()["operatingMode"] == "SERVICE" and m.last()["paused"], 10)
    master.wait("standing", lambda m: not m.last()["driving"], 10)
    held = master.last()
    assert held["orderId"] == "job5" and [n["nodeId"] for n in held["nodeStates"]] == ["b"], held
    stood_at = held["agvPosition"]["y"]
    time.sleep(2.0)
    master.instant("s1", "stateRequest")
    master.wait("a fresh state", lambda m: m.action("s1") == "FINISHED", 10)
    assert abs(master.last()["agvPosition"]["y"] - stood_at) < 0.05, "the vehicle moved in HOLD"
    assert master.last()["operatingMode"] == "SERVICE" and not master.last()["driving"]
    set_mode(gcs, AUTO)
    master.wait("AUTOMATIC again", lambda m: m.last()["operatingMode"] == "AUTOMATIC" and not m.last()["paused"], 10)
    master.wait("the order to complete", lambda m: m.last()["lastNodeId"] == "b" and not m.last()["nodeStates"], 60)
    assert sitl.alive()


def openssl(cwd, *args):
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


def make_pki(d):
    """A test CA; the broker's certificate for 127.0.0.1 and the vehicle's
    and the master's client certificates, all signed by it."""
    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes"]
    openssl(d, "req", "-x509", *ec, "-keyout", "ca.key", "-out", "ca.pem", "-days", "2", "-subj", "/CN=test-ca")
    # Extensions make X.509 v3 certificates, the only version rustls takes.
    (d / "broker.ext").write_text("subjectAltName=IP:127.0.0.1\n")
    (d / "client.ext").write_text("basicConstraints=CA:FALSE\n")
    for name in ("broker", "agv", "master"):
        openssl(d, "req", *ec, "-keyout", f"{name}.key", "-out", f"{name}.csr", "-subj", f"/CN={name}")
        ext = "broker.ext" if name == "broker" else "client.ext"
        openssl(d, "x509", "-req", "-in", f"{name}.csr", "-CA", "ca.pem", "-CAkey", "ca.key", "-CAcreateserial",
                "-out", f"{name}.pem", "-days", "2", "-extfile", ext)


def test_an_mqtts_broker_with_client_certificates_and_passwords(tmp_path, start_sitl):
    """mqtts:// against Mosquitto that requires a client certificate signed by
    its CA and a user name and password: the vehicle connects with
    --vda5050-ca/--vda5050-cert/--vda5050-key and its credentials, and
    answers; its state carries maps, loads, information and safetyState."""
    pki = tmp_path / "pki"
    pki.mkdir()
    make_pki(pki)
    subprocess.run(["mosquitto_passwd", "-b", "-c", str(pki / "passwd"), "agv", "s3cret"], check=True)
    subprocess.run(["mosquitto_passwd", "-b", str(pki / "passwd"), "master", "m4ster"], check=True)
    broker = Broker(tmp_path, settings=(
        f"cafile {pki / 'ca.pem'}\ncertfile {pki / 'broker.pem'}\nkeyfile {pki / 'broker.key'}\n"
        f"require_certificate true\nallow_anonymous false\npassword_file {pki / 'passwd'}\n"))
    try:
        master = Master(broker.port, tls=(pki / "ca.pem", pki / "master.pem", pki / "master.key"),
                        user=("master", "m4ster"))
        (tmp_path / "password").write_text("s3cret\n")
        sitl = start_sitl(speedup="5", extra_args=[
            "--vda5050", f"mqtts://127.0.0.1:{broker.port}", "--serial-number", SERIAL, "--map-id", "yard",
            "--vda5050-ca", str(pki / "ca.pem"), "--vda5050-cert", str(pki / "agv.pem"),
            "--vda5050-key", str(pki / "agv.key"),
            "--vda5050-user", "agv", "--vda5050-password-file", str(tmp_path / "password")])
        master.wait("ONLINE over TLS", lambda m: any(c["connectionState"] == "ONLINE" for c in m.connections), 20)
        master.instant("s0", "stateRequest")
        master.wait("an answer", lambda m: m.states and m.action("s0") == "FINISHED", 10)
        state = master.last()
        assert state["maps"] == [{"mapId": "yard", "mapVersion": "1", "mapStatus": "ENABLED"}]
        assert state["loads"] == [] and state["safetyState"]["eStop"] == "NONE"
        assert {i["infoType"] for i in state["information"]} >= {"mode", "gnssFix"}
        master.close()
        assert sitl.alive()
        assert "VDA 5050: connected to 127.0.0.1" in sitl.log()
    finally:
        broker.close()


def test_a_wrong_broker_password_or_tls_file_is_a_clear_error(tmp_path, start_sitl):
    (tmp_path / "empty").write_text("")
    with pytest.raises(RuntimeError, match="--vda5050-password-file: .* is empty"):
        start_sitl(extra_args=["--vda5050", "mqtt://127.0.0.1:1", "--vda5050-user", "u",
                               "--vda5050-password-file", str(tmp_path / "empty")])
    (tmp_path / "junk.pem").write_text("junk\n")
    with pytest.raises(RuntimeError, match="--vda5050-ca: .*no certificate"):
        start_sitl(extra_args=["--vda5050", "mqtts://127.0.0.1:1", "--vda5050-ca", str(tmp_path / "junk.pem")])
    with pytest.raises(RuntimeError, match="need an mqtts:// broker"):
        start_sitl(extra_args=["--vda5050", "mqtt://127.0.0.1:1", "--vda5050-ca", str(tmp_path / "junk.pem")])
