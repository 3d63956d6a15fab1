"""A Foxglove WebSocket protocol client, written from the protocol's specification
(foxglove/ws-protocol, `foxglove.websocket.v1`), independent of the bridge's code: connects,
lists the advertised channels, subscribes to one topic and prints its first N messages as JSON
lines ({"received_ns" (UNIX clock at receipt), "subprotocol", "topic", "log_time_ns", "encoding", "schema_name", "schema_encoding",
"schema", "message"}).

The official Foxglove SDK names the same protocol `foxglove.sdk.v1` (its messages are those of
`foxglove.websocket.v1`); this client offers the subprotocols given, as the Foxglove app offers
both names, and reports which one the server chose.

Usage: python foxglove_client.py ws://127.0.0.1:PORT TOPIC N [SUBPROTOCOL,...]
"""
import asyncio
import json
import struct
import sys
import time

import websockets

MESSAGE_DATA = 0x01  # binary opcode of a message on a subscription


SAME_PROTOCOL = ("foxglove.websocket.v1", "foxglove.sdk.v1")


async def main(url: str, topic: str, count: int, offered: list) -> None:
    async with websockets.connect(url, subprotocols=offered, max_size=None) as ws:
        if ws.subprotocol not in SAME_PROTOCOL:
            raise SystemExit(f"the server chose {ws.subprotocol}, not the protocol this client speaks")
        channels = {}
        subscribed = None
        schema = None
        received = 0
        while received < count:
            try:
                frame = await asyncio.wait_for(ws.recv(), timeout=10)
            except websockets.exceptions.ConnectionClosed:
                # The bridge stopped (the arm stopped): what was received is printed.
                return
            if isinstance(frame, str):
                op = json.loads(frame)
                if op.get("op") == "advertise":
                    for ch in op["channels"]:
                        channels[ch["id"]] = ch
                    wanted = [c for c in channels.values() if c["topic"] == topic]
                    if wanted and subscribed is None:
                        subscribed = wanted[0]
                        schema = json.loads(subscribed["schema"])
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": subscribed["id"]}]}))
                continue
            opcode = frame[0]
            if opcode != MESSAGE_DATA:
                continue
            subscription_id, log_time = struct.unpack_from("<IQ", frame, 1)
            if subscription_id != 1:
                raise SystemExit(f"message for subscription {subscription_id}, not 1")
            payload = frame[13:]
            print(json.dumps({
                "received_ns": time.time_ns(),
                "subprotocol": ws.subprotocol,
                "topic": subscribed["topic"],
                "log_time_ns": log_time,
                "encoding": subscribed["encoding"],
                "schema_name": subscribed["schemaName"],
                "schema_encoding": subscribed.get("schemaEncoding"),
                # The schema is parsed once (a client at 1 kHz must not re-parse it per message).
                "schema": schema if received == 0 else None,
                "message": json.loads(payload.decode("utf-8")),
            }), flush=True)
            received += 1


if __name__ == "__main__":
    offered = sys.argv[4].split(",") if len(sys.argv) > 4 else list(SAME_PROTOCOL)
    try:
        asyncio.run(main(sys.argv[1], sys.argv[2], int(sys.argv[3]), offered))
    except websockets.exceptions.InvalidStatus as e:
        raise SystemExit(f"handshake refused offering {offered}: {e}")
