"""The ROS 2 side of tests/tests/ros2_peer.rs, without a ROS install: what a ROS 2 system on
rmw_zenoh sees of fringe's node (eclipse-zenoh), the messages decoded by rosbags, and an MCAP
recording read by rosbags and by the mcap / mcap-ros2-support readers. Prints one JSON line.

    ros2_peer.py subscribe ENDPOINT COUNT    listen on ENDPOINT, take COUNT wrench messages
    ros2_peer.py read-mcap PATH
    ros2_peer.py read-run-mcap PATH          an exported run: every channel decoded by both readers
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


def stamp_ns(header_stamp):
    return header_stamp.sec * 1_000_000_000 + header_stamp.nanosec


def read_run_mcap(path):
    """Every message of an exported run decoded by rosbags' AnyReader (types from the file's
    schemas) and by mcap-ros2-support, with what the test compares against the run."""
    from rosbags.highlevel import AnyReader
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    out = {"rosbags": {}, "types": {}, "hashes": {}, "mcap_ros2": {}, "labels": [], "contacts": [],
           "shapes": [], "images": [], "ft": {"count": 0, "first": None, "last": None,
           "stamps_increasing": True}, "events": [], "log_time_is_stamp": True}
    last_ft = None
    with AnyReader([Path(path)]) as reader:
        for conn in reader.connections:
            out["types"][conn.topic] = conn.msgtype
            out["hashes"][conn.msgtype] = reader.typestore.hash_rihs01(conn.msgtype)
        for conn, timestamp, raw in reader.messages():
            m = reader.deserialize(raw, conn.msgtype)
            out["rosbags"][conn.topic] = out["rosbags"].get(conn.topic, 0) + 1
            t = stamp_ns(m.stamp if conn.msgtype == "rcl_interfaces/msg/Log" else m.header.stamp)
            if t != timestamp:
                out["log_time_is_stamp"] = False
            if conn.msgtype == "sensor_msgs/msg/Image":
                out["images"].append({"stamp": t, "width": m.width, "height": m.height,
                                      "encoding": m.encoding, "step": m.step, "bytes": len(m.data),
                                      "sum": int(m.data.astype("uint64").sum()),
                                      "frame_id": m.header.frame_id})
            elif conn.topic.endswith("/ft"):
                w = m.wrench
                v = [w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z]
                ft = out["ft"]
                ft["count"] += 1
                if ft["first"] is None:
                    ft["first"] = {"stamp": t, "wrench": v, "frame_id": m.header.frame_id}
                ft["last"] = {"stamp": t, "wrench": v}
                if last_ft is not None and t < last_ft:
                    ft["stamps_increasing"] = False
                last_ft = t
            elif conn.topic.endswith("/wrench"):
                w = m.wrench
                out["labels"].append({"stamp": t, "frame_id": m.header.frame_id, "wrench": [
                    w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z]})
            elif conn.topic.endswith("/contact"):
                out["contacts"].append({"stamp": t, "point": [m.point.x, m.point.y, m.point.z]})
            elif conn.topic.endswith("/shape"):
                out["shapes"].append({"stamp": t, "results": [[r.class_id, r.score] for r in m.results]})
            elif conn.msgtype == "rcl_interfaces/msg/Log":
                out["events"].append({"stamp": t, "level": int(m.level), "name": m.name, "msg": m.msg})
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, _message, _decoded in reader.iter_decoded_messages():
            out["mcap_ros2"][channel.topic] = out["mcap_ros2"].get(channel.topic, 0) + 1
        summary = reader.get_summary()
        out["summary"] = summary is not None
        out["profile"] = reader.get_header().profile
        out["metadata"] = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    print(json.dumps(out), flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "subscribe":
        subscribe(sys.argv[2], int(sys.argv[3]))
    elif sys.argv[1] == "read-mcap":
        read_mcap(sys.argv[2])
    elif sys.argv[1] == "read-run-mcap":
        read_run_mcap(sys.argv[2])
    else:
        sys.exit(f"unknown mode {sys.argv[1]!r}")
