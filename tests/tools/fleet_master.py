#!/usr/bin/env python3
"""A master control in one file (paho-mqtt, no pymavlink): sends one VDA 5050
order to one vehicle of a fleet and prints its state until the order is done.

    mosquitto -d -p 1883 && furrow sitl --fleet 3 --vda5050 mqtt://127.0.0.1:1883 --map-id yard
    python3 tests/tools/fleet_master.py --serial furrow-1 --north 10

The order runs from where the vehicle stands (read from its state) to
NORTH metres further north (map y), on map MAP_ID.
"""

import argparse
import json
import sys
import time

import paho.mqtt.client as mqtt


def header(serial, header_id):
    return {"headerId": header_id, "timestamp": time.strftime("%Y-%m-%dT%H:%M:%S.00Z", time.gmtime()),
            "version": "2.1.0", "manufacturer": "Furrow", "serialNumber": serial}


def node(node_id, sequence_id, x, y, map_id):
    return {"nodeId": node_id, "sequenceId": sequence_id, "released": True, "actions": [],
            "nodePosition": {"x": x, "y": y, "mapId": map_id, "allowedDeviationXY": 0.3}}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=1883)
    parser.add_argument("--serial", default="furrow-0", help="the vehicle's serial number")
    parser.add_argument("--map-id", default="yard")
    parser.add_argument("--north", type=float, default=10.0, help="metres to drive north")
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds to wait for the order to finish")
    args = parser.parse_args()
    prefix = f"uagv/v2/Furrow/{args.serial}"
    sent = {"order": False, "asked": 0.0}
    done = {"ok": False}

    def on_message(client, _userdata, message):
        state = json.loads(message.payload)
        position = state.get("agvPosition") or {}
        print(f"order {state['orderId'] or '-':>6}  last node {state['lastNodeId'] or '-':>3}  "
              f"driving {state['driving']!s:5}  x {position.get('x', float('nan')):8.2f}  "
              f"y {position.get('y', float('nan')):8.2f}  errors {[e['errorType'] for e in state['errors']]}")
        if not sent["order"] and position.get("positionInitialized"):
            x, y = position["x"], position["y"]
            order = {**header(args.serial, 1), "orderId": "example", "orderUpdateId": 0,
                     "nodes": [node("start", 0, x, y, args.map_id), node("end", 2, x, y + args.north, args.map_id)],
                     "edges": [{"edgeId": "e1", "sequenceId": 1, "released": True, "startNodeId": "start",
                                "endNodeId": "end", "actions": []}]}
            client.publish(f"{prefix}/order", json.dumps(order))
            sent["order"] = True
        elif state["orderId"] == "example" and state["lastNodeId"] == "end" and not state["nodeStates"]:
            done["ok"] = True

    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2)
    client.on_message = on_message
    client.on_connect = lambda c, _u, _f, _r, _p: c.subscribe(f"{prefix}/state")
    client.connect(args.host, args.port)
    client.loop_start()
    deadline = time.monotonic() + args.timeout
    while not done["ok"] and time.monotonic() < deadline:
        # At rest a vehicle sends its state every 30 s: ask for one.
        if not sent["order"] and time.monotonic() - sent["asked"] > 1.0:
            sent["asked"] = time.monotonic()
            request = {**header(args.serial, 1), "actions": [
                {"actionId": f"ask-{time.time_ns()}", "actionType": "stateRequest", "blockingType": "NONE"}]}
            client.publish(f"{prefix}/instantActions", json.dumps(request))
        time.sleep(0.1)
    client.loop_stop()
    client.disconnect()
    if not done["ok"]:
        print(f"{args.serial}: the order did not finish within {args.timeout:.0f} s", file=sys.stderr)
        return 1
    print(f"{args.serial}: reached node 'end'")
    return 0


if __name__ == "__main__":
    sys.exit(main())
