#!/usr/bin/env python3
"""Reads a Speleo recording as ROS 2 tools do, without ROS installed.

Checks that the file has the ros2 profile, a summary and an index (the
`mcap` package's indexed reader), then decodes every message twice: with
`mcap-ros2-support` (the decoder Foxglove's Python tools use) and with
`rosbags` (its type system built from each channel's ros2msg schema). Prints
a table per topic and exits 1 if any message fails either decoder.

Usage: ros2_check.py RECORDING.mcap
"""

import sys
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

SEPARATOR = "=" * 80


def register(typestore, schema_name, text):
    """Register a ros2msg schema (the type and its MSG: dependencies)."""
    types = {}
    name = schema_name
    block = []
    for line in text.splitlines() + [SEPARATOR]:
        if line.strip() == SEPARATOR:
            types.update(get_types_from_msg("\n".join(block), name))
            block, name = [], None
        elif line.startswith("MSG: "):
            dep = line[5:].strip()
            name = dep if "/msg/" in dep else dep.replace("/", "/msg/", 1)
        else:
            block.append(line)
    typestore.register(types)


def main(path):
    typestore = get_typestore(Stores.EMPTY)
    registered = set()
    rosbags_ok, mcap_ok, failures = Counter(), Counter(), []
    types = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        summary = reader.get_summary()
        if summary is None:
            print(f"{path}: no summary")
            return 1
        if header.profile != "ros2":
            print(f"{path}: profile {header.profile!r}, not ros2")
            return 1
        for schema in summary.schemas.values():
            if schema.name not in registered:
                register(typestore, schema.name, schema.data.decode())
                registered.add(schema.name)
        # iter_decoded_messages reads through the chunk index.
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            topic = channel.topic
            types[topic] = schema.name
            if decoded is not None:
                mcap_ok[topic] += 1
            try:
                typestore.deserialize_cdr(message.data, schema.name)
                rosbags_ok[topic] += 1
            except Exception as e:  # noqa: BLE001 - every failure is reported
                failures.append(f"{topic} @ {message.log_time}: rosbags: {e}")
        counts = summary.statistics.channel_message_counts
        channels = summary.channels
    print(f"{'topic':<22} {'type':<38} {'messages':>9} {'mcap_ros2':>10} {'rosbags':>9}")
    bad = False
    for cid, channel in sorted(channels.items()):
        n = counts.get(cid, 0)
        a, b = mcap_ok[channel.topic], rosbags_ok[channel.topic]
        bad |= a != n or b != n
        name = types.get(channel.topic, summary.schemas[channel.schema_id].name)
        print(f"{channel.topic:<22} {name:<38} {n:>9} {a:>10} {b:>9}")
    for line in failures[:10]:
        print(line)
    total = sum(counts.values())
    print(f"{total} messages; decoded by mcap-ros2-support {sum(mcap_ok.values())}, by rosbags {sum(rosbags_ok.values())}")
    return 1 if bad or failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
