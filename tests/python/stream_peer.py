"""The robot's side of `fringe stream` (tui/tests/stream_cli.rs), without a ROS install: a Zenoh
peer (eclipse-zenoh) that takes every message of the node's topics as rmw_zenoh's subscribers
would and decodes it with rosbags; and the stream's MCAP recording read by rosbags, each
prediction paired with the simulator's truth of the same frame. Prints one JSON line.

    stream_peer.py listen ENDPOINT SECONDS   listen on ENDPOINT until SECONDS pass without a message
    stream_peer.py read-mcap PATH
"""
import json
import math
import sys
import threading
import time
from pathlib import Path

TYPES = {
    "wrench": "geometry_msgs/msg/WrenchStamped",
    "contact": "geometry_msgs/msg/PointStamped",
    "shape": "vision_msgs/msg/Classification",
    "image/compressed": "sensor_msgs/msg/CompressedImage",
}


def typestore():
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg("string class_id\nfloat64 score\n", "vision_msgs/msg/ObjectHypothesis"))
    store.register(get_types_from_msg("std_msgs/Header header\nObjectHypothesis[] results\n", "vision_msgs/msg/Classification"))
    return store


def listen(endpoint, seconds):
    import zenoh
    store = typestore()
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", json.dumps([endpoint]))
    config.insert_json5("scouting/multicast/enabled", "false")
    counts, fz, contacts, shapes, keys, bad = {}, [], [], [], set(), []
    first = threading.Event()
    lock = threading.Lock()
    last = [time.monotonic()]

    def on_sample(sample):
        key = str(sample.key_expr)
        last[0] = time.monotonic()
        # <domain>/<namespace>/<topic>/<dds type>/<hash>
        parts = key.split("/")
        topic = "/".join(parts[2:-2])
        with lock:
            keys.add(key)
            try:
                m = store.deserialize_cdr(sample.payload.to_bytes(), TYPES[topic])
            except Exception as e:  # a message rosbags cannot decode is the failure under test
                bad.append(f"{key}: {e}")
                return
            counts[topic] = counts.get(topic, 0) + 1
            if topic == "wrench":
                fz.append(m.wrench.force.z)
            elif topic == "contact":
                contacts.append([m.point.x, m.point.y])
            elif topic == "shape":
                shapes.append({r.class_id: r.score for r in m.results})
            if sample.attachment is None or len(sample.attachment.to_bytes()) != 33:
                bad.append(f"{key}: attachment missing or not rmw_zenoh's 33 bytes")
        first.set()

    with zenoh.open(config) as session:
        session.declare_subscriber("0/fringe/**", on_sample)
        print("ready", flush=True)
        first.wait(120)
        # The graph while the node is up, then every message until the stream ends.
        time.sleep(1)
        tokens = [str(r.ok.key_expr) for r in session.liveliness().get("@ros2_lv/0/**") if r.ok]
        while time.monotonic() - last[0] < seconds:
            time.sleep(0.2)
    with lock:
        print(json.dumps({"counts": counts, "fz": fz, "contacts": contacts, "shapes": shapes,
                          "keys": sorted(keys), "tokens": tokens, "bad": bad}), flush=True)


def read_mcap(path):
    from rosbags.highlevel import AnyReader
    store = typestore()
    by_topic = {}
    with AnyReader([Path(path)], default_typestore=store) as reader:
        for conn, _, raw in reader.messages():
            m = reader.deserialize(raw, conn.msgtype)
            stamp = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
            by_topic.setdefault(conn.topic, {})[stamp] = m
    pred, truth = by_topic.get("/fringe/wrench", {}), by_topic.get("/fringe/truth/wrench", {})
    pred_shape, truth_shape = by_topic.get("/fringe/shape", {}), by_topic.get("/fringe/truth/shape", {})
    pairs = [(pred[s].wrench.force.z, truth[s].wrench.force.z) for s in truth if s in pred]
    fz_rmse = math.sqrt(sum((p - t) ** 2 for p, t in pairs) / len(pairs)) if pairs else None
    right = 0
    for s, t in truth_shape.items():
        p = pred_shape[s]
        best = max(p.results, key=lambda r: r.score).class_id
        right += best == t.results[0].class_id
    stamps = sorted(pred)
    print(json.dumps({
        "counts": {t: len(v) for t, v in by_topic.items()},
        "pairs": len(pairs),
        "fz_rmse": fz_rmse,
        "shape_accuracy": right / len(truth_shape) if truth_shape else None,
        "truth_in_contact": sum(1 for m in truth.values() if m.wrench.force.z >= 0.2),
        "stamps_increase": all(b > a for a, b in zip(stamps, stamps[1:])),
        "span_s": (stamps[-1] - stamps[0]) / 1e9 if stamps else 0,
    }), flush=True)


if __name__ == "__main__":
    if sys.argv[1] == "listen":
        listen(sys.argv[2], float(sys.argv[3]))
    elif sys.argv[1] == "read-mcap":
        read_mcap(sys.argv[2])
    else:
        sys.exit(f"unknown mode {sys.argv[1]!r}")
