"""A minimal Foxglove WebSocket viewer for tests (RFC 6455 client framing over a plain socket, no dependency):
connect, read the advertised channels, subscribe by topic, collect message payloads per topic."""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
import time
from typing import Any


class Viewer:
    def __init__(self, host: str, port: int, timeout: float = 5.0) -> None:
        self.sock = socket.create_connection((host, port), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                           f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                           "Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            chunk = self.sock.recv(1)
            if not chunk:
                raise ConnectionError("closed during the handshake")
            head += chunk
        if b" 101 " not in head.split(b"\r\n", 1)[0]:
            raise ConnectionError(head.decode(errors="replace"))
        self.channels: dict[str, dict[str, Any]] = {}  # topic → channel
        self.subs: dict[int, str] = {}  # subscription id → topic
        self.messages: dict[str, list[bytes]] = {}

    def _exact(self, n: int) -> bytes:
        buf = b""
        while len(buf) < n:
            chunk = self.sock.recv(n - len(buf))
            if not chunk:
                raise ConnectionError("closed")
            buf += chunk
        return buf

    def _frame(self) -> tuple[int, bytes]:
        data, opcode = b"", 0
        while True:
            b0, b1 = self._exact(2)
            opcode = opcode or (b0 & 0x0F)
            n = b1 & 0x7F
            if n == 126:
                n = struct.unpack(">H", self._exact(2))[0]
            elif n == 127:
                n = struct.unpack(">Q", self._exact(8))[0]
            mask = self._exact(4) if b1 & 0x80 else b""
            payload = self._exact(n)
            if mask:
                payload = bytes(c ^ mask[i % 4] for i, c in enumerate(payload))
            data += payload
            if b0 & 0x80:
                return opcode, data

    def _send_text(self, text: str) -> None:
        payload, mask = text.encode(), os.urandom(4)
        n = len(payload)
        head = bytes([0x81]) + (bytes([0x80 | n]) if n < 126 else bytes([0x80 | 126]) + struct.pack(">H", n))
        self.sock.sendall(head + mask + bytes(c ^ mask[i % 4] for i, c in enumerate(payload)))

    def pump(self, until: float) -> None:
        """Read frames until `until` (time.monotonic()); JSON ops update channels, binary ones are messages."""
        while time.monotonic() < until:
            self.sock.settimeout(max(0.01, until - time.monotonic()))
            try:
                opcode, data = self._frame()
            except TimeoutError:
                return
            if opcode == 1:
                msg = json.loads(data)
                if msg.get("op") == "advertise":
                    self.channels.update({c["topic"]: c for c in msg["channels"]})
            elif opcode == 2 and data[:1] == b"\x01":
                sub = struct.unpack("<I", data[1:5])[0]
                self.messages.setdefault(self.subs[sub], []).append(data[13:])

    def subscribe(self, *topics: str) -> None:
        subs = []
        for topic in topics:
            sid = len(self.subs) + 1
            self.subs[sid] = topic
            subs.append({"id": sid, "channelId": self.channels[topic]["id"]})
        self._send_text(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def wait_for(self, topic: str, timeout: float = 5.0) -> list[bytes]:
        deadline = time.monotonic() + timeout
        while not self.messages.get(topic) and time.monotonic() < deadline:
            self.pump(min(deadline, time.monotonic() + 0.2))
        return self.messages.get(topic, [])

    def close(self) -> None:
        self.sock.close()
