"""Decodes an MCAP file with the official readers (mcap, mcap-ros2-support) and prints one
JSON line per message: topic, schema, log time and the decoded fields. The host's tests
compare these with what the device sent."""

import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def plain(v):
    """A decoded ROS message as plain JSON values."""
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, (bytes, bytearray)):
        return list(v)
    if hasattr(v, "__slots__"):
        return {k: plain(getattr(v, k)) for k in v.__slots__}
    return v


def main(path):
    ros = DecoderFactory()
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema, channel, message in reader.iter_messages():
            if channel.message_encoding == "cdr":
                decoder = ros.decoder_for(channel.message_encoding, schema)
                body = plain(decoder(message.data))
            elif channel.message_encoding == "json":
                body = json.loads(message.data)
            else:
                raise SystemExit(f"unexpected encoding {channel.message_encoding}")
            print(json.dumps({
                "topic": channel.topic,
                "schema": schema.name,
                "schema_encoding": schema.encoding,
                "log_time": message.log_time,
                "sequence": message.sequence,
                "body": body,
            }))


if __name__ == "__main__":
    main(sys.argv[1])
