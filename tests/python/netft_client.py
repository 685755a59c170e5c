"""An independent Net F/T client (pynetft, from PyPI) against fringe's emulated Net F/T box.

Usage: netft_client.py HOST RDT_PORT HTTP_PORT SAMPLES

pynetft discovers the calibration from http://HOST:HTTP_PORT/netftapi2.xml, starts RDT real-time
streaming on UDP RDT_PORT and checks the sequence numbers itself. The script prints one JSON object
per line for the Rust test (tests/tests/netft_emulator.rs) to check:
  {"phase": "stream", ...}  SAMPLES samples before the bias: mean wrench, units, sequence checks
  {"phase": "biased", ...}  SAMPLES samples after the software bias command
  {"phase": "health_before_bias", ...}, {"phase": "health", ...}  pynetft's own stream health
      (lost, out of order, faults) before the bias and at the end. pynetft restarts the stream after
      a bias; the box numbers the new stream from 1 again, which pynetft counts as out of order.
"""

import json
import sys
import time

from pynetft import Client, Config


def take(samples, n):
    got = []
    for sample in samples:
        got.append(sample)
        if len(got) >= n:
            break
    return got


def summary(phase, got):
    n = len(got)
    mean = [sum(s.wrench[i] for s in got) / n for i in range(6)]
    raw_mean = [sum(s.raw_wrench[i] for s in got) / n for i in range(6)]
    ft = [s.ft_sequence for s in got]
    rdt = [s.rdt_sequence for s in got]
    return {
        "phase": phase,
        "count": n,
        "mean": mean,
        "raw_mean": raw_mean,
        "force_unit": got[0].force_unit.value,
        "torque_unit": got[0].torque_unit.value,
        "status_nonzero": sum(1 for s in got if s.status != 0),
        "ft_increasing": all(b > a for a, b in zip(ft, ft[1:])),
        "rdt_increasing": all(b > a for a, b in zip(rdt, rdt[1:])),
        "first_rdt": rdt[0],
    }


def health(phase, h):
    return {
        "phase": phase,
        "product": h.sensor_configuration.product_name,
        "lost": h.lost_count,
        "out_of_order": h.out_of_order_count,
        "duplicates": h.duplicate_count,
        "malformed": h.malformed_count,
        "device_errors": h.device_error_count,
        "fault": h.fault_code.value,
        "ft_stall": h.ft_stall_count,
        "ft_backward": h.ft_backward_count,
    }


def main():
    host, rdt_port, http_port, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    config = Config(sensor_host=host, rdt_port=rdt_port, http_port=http_port, receive_timeout=1.0)
    # A queue large enough that Python's pace drops nothing while the test reads.
    with Client(config, queue_size=100000) as client:
        if not client.wait_for_first_sample(5.0):
            print(json.dumps({"phase": "error", "message": "no sample within 5 s"}), flush=True)
            return 1
        samples = client.samples(timeout=2.0)
        print(json.dumps(summary("stream", take(samples, n))), flush=True)
        print(json.dumps(health("health_before_bias", client.health())), flush=True)
        client.bias()
        # Records already in flight were measured before the bias.
        time.sleep(0.2)
        while True:
            s = next(samples)
            if all(abs(v) < 1e-3 for v in s.raw_wrench):
                break
        print(json.dumps(summary("biased", take(samples, n))), flush=True)
        print(json.dumps(health("health", client.health())), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
