"""The ROS 2 side of tests/tests/ros2_peer.rs, without a ROS install: what a ROS 2 system on
rmw_zenoh sees of fringe's node (eclipse-zenoh), the messages decoded by rosbags, and an MCAP
recording read by rosbags and by the mcap / mcap-ros2-support readers. Prints one JSON line.

    ros2_peer.py subscribe ENDPOINT COUNT    listen on ENDPOINT, take COUNT wrench messages
    ros2_peer.py read-mcap PATH
"""
import json
import struct
import sys
import threading
from pathlib import Path


def vision_types(store):
    from rosbags.typesys import get_types_from_msg
    store.register(get_types_from_msg("string class_id\nfloat64 score\n", "vision_msgs/msg/ObjectHypothesis"))
    store.register(get_types_from_msg("std_msgs/Header header\nObjectHypothesis[] results\n", "vision_msgs/msg/Classification"))


def subscribe(endpoint, count):
    import zenoh
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    got, done = [], threading.Event()

    def on_sample(sample):
        if len(got) >= count:
            return
        att = sample.attachment.to_bytes()
        seq, sent_ns, n = struct.unpack_from("<qqB", att)
        m = store.deserialize_cdr(sample.payload.to_bytes(), "geometry_msgs/msg/WrenchStamped")
        got.append({"key": str(sample.key_expr), "attachment_len": len(att), "seq": seq,
                    "sent_ns": sent_ns, "gid_len": n, "gid": att[17:].hex(),
                    "fz": m.wrench.force.z, "frame_id": m.header.frame_id})
        if len(got) == count:
            done.set()

    with zenoh.open(config) as session:
        session.declare_subscriber("0/fringe/wrench/**", on_sample)
        print("ready", flush=True)
        done.wait(30)
        tokens = [str(r.ok.key_expr) for r in session.liveliness().get("@ros2_lv/0/**") if r.ok]
    print(json.dumps({"messages": got, "tokens": tokens,
                      "hash": store.hash_rihs01("geometry_msgs/msg/WrenchStamped")}), flush=True)


def read_mcap(path):
    from rosbags.highlevel import AnyReader
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    out = {"rosbags": {}, "mcap_ros2": 0, "fz": []}
    with AnyReader([Path(path)]) as reader:
        for conn, _, raw in reader.messages():
            m = reader.deserialize(raw, conn.msgtype)
            out["rosbags"][conn.topic] = out["rosbags"].get(conn.topic, 0) + 1
            if conn.msgtype == "geometry_msgs/msg/WrenchStamped":
                out["fz"].append(m.wrench.force.z)
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, _channel, _message, _decoded in reader.iter_decoded_messages():
            out["mcap_ros2"] += 1
        out["summary"] = reader.get_summary() is not None
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "subscribe":
        subscribe(sys.argv[2], int(sys.argv[3]))
    elif sys.argv[1] == "read-mcap":
        read_mcap(sys.argv[2])
    else:
        sys.exit(f"unknown mode {sys.argv[1]!r}")
