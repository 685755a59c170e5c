"""Prints the force a fringe stream publishes, with no ROS install: a Zenoh subscriber on the
wrench topic as rmw_zenoh names it, decoding the CDR with rosbags.

    pip install eclipse-zenoh==1.10.2 rosbags==0.11.9
    python examples/zenoh_wrench.py [ENDPOINT]        # default tcp/127.0.0.1:7447 (rmw_zenohd)
"""
import struct
import sys
import time

import zenoh
from rosbags.typesys import Stores, get_typestore

types = get_typestore(Stores.ROS2_JAZZY)
config = zenoh.Config()
config.insert_json5("connect/endpoints", '["%s"]' % (sys.argv[1] if len(sys.argv) > 1 else "tcp/127.0.0.1:7447"))


def on_wrench(sample):
    sequence, sent_ns = struct.unpack_from("<qq", sample.attachment.to_bytes())
    m = types.deserialize_cdr(sample.payload.to_bytes(), "geometry_msgs/msg/WrenchStamped")
    f = m.wrench.force
    print(f"{sequence:6d}  {m.header.stamp.sec}.{m.header.stamp.nanosec:09d}  Fx {f.x:7.3f}  Fy {f.y:7.3f}  Fz {f.z:7.3f} N", flush=True)


with zenoh.open(config) as session:
    # Domain 0, namespace /fringe; `**` matches the type name and hash that follow.
    session.declare_subscriber("0/fringe/wrench/**", on_wrench)
    while True:
        time.sleep(1)
