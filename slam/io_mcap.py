"""LaserScan input from MCAP recordings (ROS 2 bags in MCAP, Foxglove recordings), and a small writer.

Channels are recognised by schema: `sensor_msgs/msg/LaserScan` (CDR, or JSON with ROS field names) and
`foxglove.LaserScan` (protobuf or JSON). Other channels are skipped.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Literal

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import Writer

from sim.errors import ErrorCode, FleetError
from sim.types import LidarScan
from slam.laserscan_codecs import (
    ROS2_LASERSCAN,
    ROS2_LASERSCAN_MSGDEF,
    decode_cdr,
    decode_foxglove_protobuf,
    decode_json,
    encode_cdr,
    encode_json,
)
from slam.types import ScanRecord

Decoder = Callable[[bytes, str], LidarScan]
_SCHEMAS = (ROS2_LASERSCAN, "sensor_msgs/LaserScan", "foxglove.LaserScan")


def _decoder(schema_name: str, message_encoding: str) -> Decoder | None:
    if schema_name not in _SCHEMAS:
        return None
    if message_encoding == "cdr":
        return decode_cdr
    if message_encoding == "json":
        return decode_json
    if message_encoding == "protobuf" and schema_name == "foxglove.LaserScan":
        return decode_foxglove_protobuf
    raise FleetError(ErrorCode.UNSUPPORTED, f"{schema_name} messages encoded as '{message_encoding}' are not "
                     "supported", "use cdr, json, or protobuf (foxglove.LaserScan)")


def read_mcap_scans(path: str | Path, topic: str | None = None, robot: str = "robot") -> Iterator[ScanRecord]:
    """Every LaserScan in the file (or on `topic`), in log-time order, as ScanRecords without odometry."""
    p = Path(path)
    try:
        with p.open("rb") as f:
            found = False
            reader = make_reader(f)
            for schema, channel, message in reader.iter_messages(topics=[topic] if topic else None,
                                                                 log_time_order=True):
                dec = _decoder(schema.name if schema else "", channel.message_encoding)
                if dec is None:
                    continue
                found = True
                yield ScanRecord(dec(message.data, robot))
    except OSError as exc:
        raise FleetError(ErrorCode.NOT_FOUND, f"cannot read {p}: {exc.strerror}", "check the path") from exc
    except McapError as exc:
        raise FleetError(ErrorCode.INVALID_ARGUMENT, f"{p}: not a valid MCAP file: {exc}") from exc
    if not found:
        raise FleetError(ErrorCode.NOT_FOUND, f"{p}: no LaserScan messages" + (f" on topic {topic}" if topic else ""),
                         f"expected a channel with schema {' or '.join(_SCHEMAS)}")


def write_mcap_scans(path: str | Path, scans: Iterable[LidarScan], topic: str = "/scan",
                     encoding: Literal["cdr", "json"] = "cdr") -> int:
    """Write scans as sensor_msgs/msg/LaserScan (ROS 2 CDR or JSON); returns the message count."""
    n = 0
    with Path(path).open("wb") as f:
        w = Writer(f)
        w.start(profile="ros2" if encoding == "cdr" else "", library="fleetnav.slam")
        if encoding == "cdr":
            sid = w.register_schema(ROS2_LASERSCAN, "ros2msg", ROS2_LASERSCAN_MSGDEF.encode())
        else:
            sid = w.register_schema(ROS2_LASERSCAN, "jsonschema", json.dumps({"type": "object"}).encode())
        cid = w.register_channel(topic, encoding, sid)
        for scan in scans:
            t = round(scan.stamp * 1e9)
            w.add_message(cid, log_time=t, publish_time=t, sequence=n,
                          data=encode_cdr(scan) if encoding == "cdr" else encode_json(scan))
            n += 1
        w.finish()
    return n
