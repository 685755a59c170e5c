#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets (fuzz/corpus/<target>/) from the project's own
files: the device traces, plans, maps, rig and sensor files, the ATI calibration files, tiny model
files made with PyTorch / onnx (when importable), and a recorded run.

    fuzz/make_seeds.py [--run RUN_DIR]

RUN_DIR is a run that `fringe` recorded (e.g. `fringe demo --no-tui` writes one under runs/).
Seeds are small on purpose: libFuzzer mutates them, and the replay test runs them all.
"""
import argparse
import collections
import pathlib
import pickle
import struct
import json

ROOT = pathlib.Path(__file__).resolve().parent.parent
CORPUS = ROOT / "fuzz" / "corpus"


def put(target, name, data):
    d = CORPUS / target
    d.mkdir(parents=True, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    (d / name).write_bytes(data)


def trace_lines(path):
    """(direction, bytes) of each entry of a fringe trace."""
    out = []
    for line in path.read_text().splitlines():
        s = line.split("#", 1)[0].split()
        if len(s) >= 2 and s[1] in "<>" and len(s[1]) == 1:
            out.append((s[1], bytes(int(h, 16) for h in s[2:])))
    return out


def seeds_from_traces():
    for t in sorted((ROOT / "tests/traces/apt").glob("*.trace")):
        lines = trace_lines(t)
        put("apt", t.stem + ".from_device", b"".join(b for d, b in lines if d == "<"))
        put("apt", t.stem + ".to_device", b"".join(b for d, b in lines if d == ">"))
    for t in sorted((ROOT / "tests/traces/netft").glob("*.trace")):
        lines = trace_lines(t)
        ds = [b for d, b in lines if d == "<" and b]
        rq = [b for d, b in lines if d == ">" and b]
        for i, b in enumerate(ds[:2]):
            put("rdt", f"{t.stem}.{i}", b)
        if rq:
            put("rdt", f"{t.stem}.request", rq[0])
    for t in sorted((ROOT / "tests/traces/ystage").glob("*.trace")):
        seen = set()
        for d, b in trace_lines(t):
            if b and b not in seen and len(seen) < 6:
                seen.add(b)
                put("modbus", f"{t.stem}.{len(seen)}", b)
    for t in sorted((ROOT / "tests/traces").glob("*/*.trace")):
        put("trace", f"{t.parent.name}.{t.stem}", t.read_bytes())


def seeds_from_files():
    for p in sorted((ROOT / "tui/app/plans").glob("*.toml")):
        put("plan", p.name, p.read_bytes())
    for p in sorted((ROOT / "tui/app/rigs").glob("*.toml")):
        put("rig_file", p.name, p.read_bytes())
    for p in sorted((ROOT / "rig/maps").glob("*.toml")):
        put("register_map", p.name, p.read_bytes())
    for p in sorted((ROOT / "rig/sim/sensors").glob("*.toml")):
        put("sensor_file", p.name, p.read_bytes())
    for p in sorted((ROOT / "tests/data").glob("*.cal")) + [ROOT / "rig/sim/sim-data/sim-mini40.cal"]:
        put("cal_file", p.name, p.read_bytes())
    doc = (ROOT / "docs/calibration.md").read_text()
    start = doc.index('```toml\nsensor_id') + len("```toml\n")
    put("profile", "docs.toml", doc[start:doc.index("```", start)])
    xml = ("<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n<netft>\n<setserial>FT01234</setserial>\n"
           "<prodname>Nano17</prodname>\n<cfgcpf>1000000</cfgcpf>\n<cfgcpt>1000000</cfgcpt>\n"
           "<scfgfu>N</scfgfu>\n<scfgtu>Nm</scfgtu>\n<comrdtrate>5000</comrdtrate>\n"
           "<comrdtbsiz>1</comrdtbsiz>\n</netft>\n")
    put("netft_xml", "netftapi2.xml", xml)
    put("netft_xml", "http_reply", "HTTP/1.1 200 OK\r\nContent-Type: text/xml\r\n"
        f"Content-Length: {len(xml)}\r\n\r\n{xml}")


def force_log(records):
    head = b"FRNGFT01" + struct.pack("<I", 80) + b"\0" * 4
    body = b""
    for i in range(records):
        # device tick, transport sequence, status, host time (ns), wrench, strobe (V), padding
        body += struct.pack("<QIIQ", 200 * i, i, 0, 1_000_000 * i)
        body += struct.pack("<6d", 0.0, 0.0, -1.5 * i, 0.0, 0.0, 0.0)
        body += struct.pack("<f4x", float("nan") if i % 2 else 2.5)
    return head + body


def fgl(width, height, pattern, payload):
    """A small FGL image (rig/src/store/frames/fgl.rs): one context whose symbols 0 and 1 have
    1-bit codes, so every payload bit is a pixel's residual of 0 or -1."""
    lengths = bytes([0x11]) + bytes(127)
    return (b"FGL1" + struct.pack("<II", width, height) + bytes([pattern, 1]) + lengths
            + payload)


def seeds_binary():
    put("fgl", "mono_4x4", fgl(4, 4, 0, b"\xa5\x3c"))
    put("fgl", "mosaic_6x2", fgl(6, 2, 1, b"\x0f\xf0"))
    put("force_log", "three_records", force_log(3))
    put("force_log", "header_only", force_log(0))
    put("force_log", "torn_record", force_log(2)[:-17])
    od = collections.OrderedDict([("a", 1), ("b", [1.5, None, True]), ("c", (b"x", "y"))])
    for proto in (2, 3, 4, 5):
        put("pickle", f"ordered_dict.p{proto}", pickle.dumps(od, protocol=proto))
    put("pickle", "nested.p2", pickle.dumps({"model_state_dict": od, "epoch": 3}, protocol=2))


def seeds_models():
    put("model_file", "views.pth", b"\x00" + (ROOT / "sensor-models/tests/fixtures/custom/views.pth").read_bytes())
    header = json.dumps({"w": {"dtype": "F32", "shape": [2, 2], "data_offsets": [0, 16]},
                         "__metadata__": {"format": "pt"}}).encode()
    st = struct.pack("<Q", len(header)) + header + struct.pack("<4f", 1, 2, 3, 4)
    put("model_file", "tiny.safetensors", b"\x02" + st)
    try:
        import torch
        sd = collections.OrderedDict([("force_head.weight", torch.arange(6.0).reshape(2, 3)),
                                      ("force_head.bias", torch.zeros(2, dtype=torch.float16))])
        import io
        buf = io.BytesIO()
        torch.save(sd, buf)
        put("model_file", "tiny_zip.pth", b"\x00" + buf.getvalue())
        buf = io.BytesIO()
        torch.save({"model_state_dict": sd}, buf, _use_new_zipfile_serialization=False)
        put("model_file", "tiny_legacy.pth", b"\x00" + buf.getvalue())
    except ImportError:
        print("torch not importable: the torch seeds are left as they are")
    try:
        import onnx
        from onnx import helper, TensorProto
        x = helper.make_tensor_value_info("input", TensorProto.FLOAT, [1, 3, 224, 224])
        outs = [helper.make_tensor_value_info(n, TensorProto.FLOAT, None) for n in ("force", "shape", "contact")]
        nodes = [helper.make_node("ReduceMean", ["input"], [n], keepdims=0) for n in ("force", "shape", "contact")]
        model = helper.make_model(helper.make_graph(nodes, "tiny", [x], outs))
        put("model_file", "tiny.onnx", b"\x03" + model.SerializeToString())
    except ImportError:
        print("onnx not importable: the onnx seed is left as it is")


def seeds_run(run):
    run = pathlib.Path(run)
    names = ["start.json", "frames.jsonl", "stop.json", "checkpoint.json", "force.bin"]
    parts = []
    for n in names:
        p = run / n
        data = p.read_bytes() if p.exists() else b""
        if n == "frames.jsonl":
            data = b"".join(data.splitlines(keepends=True)[:4])
        if n == "force.bin":
            data = data[:16 + 80 * 6]
        parts.append(data)
    put("run_dir", "recorded", b"\xff".join(parts))
    put("run_dir", "no_stop", b"\xff".join(parts[:2] + [b"", parts[3], parts[4]]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--run")
    a = ap.parse_args()
    seeds_from_traces()
    seeds_from_files()
    seeds_binary()
    seeds_models()
    if a.run:
        seeds_run(a.run)


main()
