"""A small Foxglove WebSocket client for the tests (the protocol Foxglove's app speaks to ``--live``).

Subprotocol ``foxglove.sdk.v1`` (the SDK's; its messages are those of ``foxglove.websocket.v1``): the server advertises its channels (JSON
text), the client subscribes, and each message comes as a binary frame: opcode
1, subscription id (uint32), log time (uint64 ns), payload. Protobuf payloads
(``/scene``) are decoded with the schema the server advertised.
"""
from __future__ import annotations

import base64
import json
import struct

from websockets.sync.client import connect

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]  # the SDK's server speaks the first
_MESSAGE_DATA = 0x01
_HEAD = struct.Struct("<BIQ")


class Client:
    """``with Client(url) as client:`` ..."""

    def __init__(self, url: str, timeout_s: float = 30):
        self._connection = connect(url, subprotocols=SUBPROTOCOLS, open_timeout=timeout_s, max_size=None)
        self.timeout_s = timeout_s
        self.channels: dict[str, dict] = {}  # topic -> advertised channel
        self._topics: dict[int, str] = {}  # subscription id -> topic

    def wait_for_channels(self, topics: set[str]) -> dict[str, dict]:
        """Read the server's text messages until every topic in ``topics`` is advertised."""
        while not topics <= self.channels.keys():
            message = self.ws.recv(timeout=self.timeout_s)
            if isinstance(message, str):
                self._text(json.loads(message))
        return self.channels

    def _text(self, message: dict) -> None:
        if message.get("op") == "advertise":
            for channel in message["channels"]:
                self.channels[channel["topic"]] = channel

    def subscribe(self, topics: list[str]) -> None:
        subscriptions = []
        for number, topic in enumerate(topics, start=1):
            self._topics[number] = topic
            subscriptions.append({"id": number, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def messages(self):
        """(topic, log time ns, payload bytes) as they come, until the server closes."""
        while True:
            try:
                message = self.ws.recv(timeout=self.timeout_s)
            except Exception:  # noqa: BLE001 - the run ended and the server went away
                return
            if isinstance(message, str):
                self._text(json.loads(message))
            elif message[0] == _MESSAGE_DATA:
                _, subscription, t_ns = _HEAD.unpack_from(message)
                yield self._topics[subscription], t_ns, message[_HEAD.size:]

    def protobuf_class(self, topic: str):
        """The message class of a protobuf channel, from the schema the server advertised."""
        from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

        channel = self.channels[topic]
        files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
        pool = descriptor_pool.DescriptorPool()
        for file in files.file:
            pool.Add(file)
        return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))

    def __enter__(self) -> "Client":
        self.ws = self._connection.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        self._connection.__exit__(*exc)
