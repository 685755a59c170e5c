"""The Python side of tui/tests/python_package.rs: the fringe package against fringe's own reading
(an MCAP export of the run, which holds its frames as stored; its JSON documents, read by Python's
json; its PNG frames, read by Pillow) and against what `fringe eval` prints.

    check_package.py same-as-fringe RUN MCAP   frames, labels, metadata and events as fringe reads
    check_package.py same-run A B              A and B read alike (a run and its copy in an older layout)
    check_package.py refused RUN               opening RUN raises RunError (its message printed)
    check_package.py damaged RUN INDEX         frame INDEX is damaged: raised, or skipped when asked
    check_package.py incomplete RUN N          a run not closed: warned, its N whole records read
    check_package.py eval-figures RUN MODEL CSV  MODEL's predictions on RUN's labelled frames from
                                               Python's inputs against `fringe eval --predictions CSV`
    check_package.py for-run RUN PROFILES      the model fringe.Model.for_run picks (its path)
    check_package.py same-weights A B          two safetensors files hold the same tensors within
                                               1e-5, moved from their initial values by training
    check_package.py torch-vs-fringe MODEL RUN CSV   PyTorch's outputs of MODEL (a network trained
                                               here) on RUN's labelled frames against `fringe eval
                                               --predictions CSV`, within 1e-4
    check_package.py bad-card MODEL            fringe.Model refuses MODEL (its card does not match)
    check_package.py dataset RUN               fringe.torch.Dataset: the split by press, batches,
                                               the augmentation pipelines
    check_package.py reference DS              fringe.torch.Source and Dataset over a reference-layout
                                               dataset DS (fringe sim dataset): its labels as its
                                               0.labels.csv says, split, inputs kept in 8 bits
    check_package.py shards DIR RUN...         the WebDataset shards in DIR, read by webdataset,
                                               hold RUN's frames and labels

Each check exits non-zero with what differed; on success it prints one JSON line.
"""
import json
import math
import sys
import warnings
from pathlib import Path

import numpy as np

import fringe


def fail(message):
    print(message, file=sys.stderr)
    sys.exit(1)


def check(cond, message):
    if not cond:
        fail(message)


def json_lines(path):
    out = []
    if not path.exists():
        return out
    for line in path.read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            pass  # a torn last line, as fringe leaves it out
    return out


def mcap_images(path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    images = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            if channel.topic.endswith("/image"):
                images.append(msg)
    return images


ENCODING = {"mono8": ("mono8", 1), "rgb8": ("rgb8", 3), "bayerrg8": ("bayer_rggb8", 1)}


def same_as_fringe(run_dir, mcap_path):
    run_dir = Path(run_dir)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run = fringe.Run(run_dir)
    records = json_lines(run_dir / "frames.jsonl")
    start = json.loads((run_dir / "start.json").read_text())
    check(len(run) == len(records) > 0, f"len(run) {len(run)}, frames.jsonl {len(records)}")
    # Metadata as the start document says.
    for key in ("run_id", "sensor_id", "plan", "rig", "sync_method"):
        check(run.metadata[key] == start[key], f"metadata {key} differs")
    check(run.frame_storage == start["frames"], f"{run.frame_storage} vs {start['frames']}")
    # Frames: every one as fringe's MCAP export holds it, byte for byte.
    images = mcap_images(mcap_path)
    check(len(images) == len(run), f"{len(images)} images in the export, {len(run)} frames")
    encoding, channels = ENCODING[run.pixel_format]
    for i, img in enumerate(images):
        f = run.frame(i)
        check(f.dtype == np.uint8, f"frame {i}: dtype {f.dtype}")
        want_shape = (img.height, img.width) if channels == 1 else (img.height, img.width, 3)
        check(f.shape == want_shape, f"frame {i}: shape {f.shape}, export {want_shape}")
        check(img.encoding == encoding, f"frame {i}: export encoding {img.encoding}")
        check(f.tobytes() == bytes(img.data), f"frame {i}: pixels differ from fringe's export")
    if run.crop is not None:
        crop = run.crop
        check(run.frame(0).shape[:2] == (crop["roi"]["height"], crop["roi"]["width"]),
              f"a disc-crop run's frame is its cutout: {run.frame(0).shape} vs {crop}")
    # Frames in PNG files: as Pillow reads them too.
    if start["frames"]["encoding"] == "png":
        from PIL import Image

        for i in (0, len(run) // 2, len(run) - 1):
            with Image.open(run_dir / records[i]["file"]) as im:
                check(np.array_equal(np.asarray(im), run.frame(i)), f"frame {i}: differs from Pillow's")
    # Labels: every field of every record, as recorded.
    labels = run.labels()
    check(len(labels) == len(records), "one label row per record")
    axes = {"fx": "fx", "fy": "fy", "fz": "fz", "mx": "tx", "my": "ty", "mz": "tz"}
    for r, (_, row) in zip(records, labels.iterrows()):
        i = r["index"]
        check(row["index"] == i and row["frame_id"] == r["frame_id"] and row["point"] == r["point"],
              f"record {i}: ids differ")
        check(bool(row["valid"]) == r["valid"], f"record {i}: valid")
        check(row["shape"] == r["shape"], f"record {i}: shape {row['shape']} vs {r['shape']}")
        w = r.get("wrench")
        for col, key in axes.items():
            want = math.nan if w is None else w[key]
            got = row[col]
            check((math.isnan(want) and math.isnan(got)) or got == want,
                  f"record {i}: {col} {got!r} vs {want!r}")
        c = r.get("contact")
        for k, col in enumerate(("contact_x_mm", "contact_y_mm")):
            want = math.nan if c is None else c[k]
            check((math.isnan(want) and math.isnan(row[col])) or row[col] == want,
                  f"record {i}: {col}")
        q = r.get("shear")
        for k, col in enumerate(("shear_x_n", "shear_y_n")):
            want = math.nan if q is None else q[k]
            check((math.isnan(want) and math.isnan(row[col])) or row[col] == want,
                  f"record {i}: {col}")
        slip = row["slip"]
        missing = slip is None or (isinstance(slip, float) and math.isnan(slip))
        check(missing or slip in ("stick", "partial_slip", "gross_slip"), f"record {i}: slip {slip!r}")
        if q is None:
            check(missing, f"record {i}: a slip label without the shear it comes from")
        e = r.get("exposure")
        if e is not None:
            check(row["exposure_start_ns"] == e["start_ns"] and row["exposure_end_ns"] == e["end_ns"],
                  f"record {i}: exposure window")
        check(row["host_arrival_ns"] == r["host_arrival_ns"], f"record {i}: arrival")
        check(row["commanded_x_mm"] == r["commanded"]["x"], f"record {i}: commanded x")
        check(row["file"] == r["file"], f"record {i}: file")
    # The training labels: fringe's label rules on the valid records.
    t = run.training_labels()
    valid = [r for r in records if r["valid"] and r.get("wrench") is not None]
    check(list(t["index"]) == [r["index"] for r in valid], "training frames are the valid ones")
    for k, r in enumerate(valid):
        check(t["force"][k][2] == abs(r["wrench"]["fz"]), f"record {r['index']}: |Fz| label")
        check(t["press"][k] == f"{start['run_id']}#{r['point']}", f"record {r['index']}: press")
    # Events.
    events = json_lines(run_dir / "events.jsonl")
    check(run.events() == events, "events differ from events.jsonl")
    check(run.closed, "a finished run reads as closed")
    print(json.dumps({"frames": len(run), "pixel_format": run.pixel_format,
                      "encoding": start["frames"]["encoding"], "crop": run.crop is not None,
                      "labelled": len(t["index"])}))


def same_run(a, b):
    ra, rb = fringe.Run(a), fringe.Run(b)
    check(len(ra) == len(rb), f"{len(ra)} vs {len(rb)} frames")
    check(ra.pixel_format == rb.pixel_format, f"{ra.pixel_format} vs {rb.pixel_format}")
    for i in range(len(ra)):
        check(np.array_equal(ra.frame(i), rb.frame(i)), f"frame {i} differs")
    la, lb = ra.label_arrays(), rb.label_arrays()
    for k in la:
        x, y = la[k], lb[k]
        if isinstance(x, np.ndarray) and x.dtype.kind == "f":
            check(np.array_equal(x, y, equal_nan=True), f"label {k} differs")
        else:
            check(list(x) == list(y), f"label {k} differs")
    print(json.dumps({"frames": len(ra), "layout": rb.metadata["layout_version"]}))


def refused(run_dir):
    try:
        fringe.Run(run_dir)
    except fringe.RunError as e:
        print(json.dumps({"message": str(e)}))
        return
    fail(f"{run_dir} opened")


def damaged(run_dir, index):
    index = int(index)
    run = fringe.Run(run_dir)
    try:
        run.frame(index)
        fail(f"frame {index} read")
    except fringe.FrameError as e:
        message = str(e)
    frames, kept = run.frames(on_damaged="skip")
    check(index not in kept and len(kept) == len(run) - 1 and len(frames) == len(kept),
          f"skipping kept {len(kept)} of {len(run)}")
    try:
        run.frames()
        fail("frames() read every frame")
    except fringe.FrameError:
        pass
    inputs, kept = run.inputs(size=64, on_damaged="skip", return_indices=True)
    check(inputs.shape == (len(run) - 1, 3, 64, 64) and index not in kept, f"inputs {inputs.shape}")
    print(json.dumps({"message": message}))


def incomplete(run_dir, n):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = fringe.Run(run_dir)
    said = [str(w.message) for w in caught if issubclass(w.category, fringe.IncompleteRunWarning)]
    check(said, "no IncompleteRunWarning")
    check(len(run) == int(n), f"{len(run)} frames read, {n} whole records")
    check(not run.closed, "reads as closed")
    run.frame(len(run) - 1)
    print(json.dumps({"warning": said[0], "frames": len(run)}))


def eval_figures(run_dir, model_name, predictions_csv):
    import csv

    run = fringe.Run(run_dir)
    model = fringe.Model(model_name)
    t = run.training_labels()
    inputs = run.inputs(model, indices=t["index"])
    check(inputs.dtype == np.float32 and inputs.shape[1:] == (3, model.input_size, model.input_size),
          f"inputs {inputs.dtype} {inputs.shape}")
    from_inputs = model.predict(inputs)
    from_run = model.predict_run(run, indices=t["index"])
    for k in ("fx", "fz", "contact_raw_x_mm", "probabilities"):
        check(np.array_equal(from_inputs[k], from_run[k]), f"{k}: predict(inputs) differs from predict_run")
    # fringe eval's own rows, frame by frame: the same frames, labels and predictions, bit for bit.
    with open(predictions_csv, newline="") as f:
        rows = list(csv.DictReader(f))
    check(len(rows) == len(t["index"]), f"fringe eval scored {len(rows)} frames, Python {len(t['index'])}")
    for k, row in enumerate(rows):
        frame = int(t["index"][k])
        check(row["press"] == t["press"][k], f"frame {frame}: press {row['press']} vs {t['press'][k]}")
        check(float(row["fz_true"]) == t["force"][k][2], f"frame {frame}: Fz label")
        check(row["shape_true"] == t["shape"][k], f"frame {frame}: shape label")
        check(float(row["fz_pred"]) == from_inputs["fz"][k],
              f"frame {frame}: Fz {from_inputs['fz'][k]!r} from Python's inputs, {row['fz_pred']} in fringe eval")
        check(row["shape_pred"] == from_inputs["shape"][k], f"frame {frame}: shape")
        check(float(row["contact_pred_x_mm"]) == from_inputs["contact_raw_x_mm"][k]
              and float(row["contact_pred_y_mm"]) == from_inputs["contact_raw_y_mm"][k],
              f"frame {frame}: contact")
    # Camera frames given as arrays, in the run's pixel format, with its profile as a file: the
    # same predictions (a disc-crop run's frames are cutouts, which only the run itself places).
    if run.crop is None:
        profile = Path(predictions_csv).with_suffix(".profile.toml")
        profile.write_text(json.loads((Path(run_dir) / "start.json").read_text())["calibration_profile"]["content"])
        first = [int(i) for i in t["index"][:8]]
        on_frames = model.predict([run.frame(i) for i in first], pixel_format=run.pixel_format,
                                  profile=profile)
        check(np.array_equal(on_frames["fz"], from_run["fz"][:8]),
              "predict(frames) differs from predict_run on the same frames")
    err = from_run["fz"] - t["force"][:, 2]
    correct = sum(1 for s, p in zip(t["shape"], from_run["shape"]) if s == p)
    n = len(err)
    print(json.dumps({"n": n, "fz_mse": float(np.mean(err * err)),
                      "fz_rmse": float(math.sqrt(np.mean(err * err))), "accuracy": correct / n}))


def for_run(run_dir, profiles):
    model = fringe.Model.for_run(fringe.Run(run_dir), profiles=profiles)
    print(json.dumps({"path": str(model.path), "notes": model.notes}))


def load_net(path):
    from safetensors.torch import load_file

    from fringe.nets import build

    card = json.loads(Path(path).with_suffix(".json").read_text())
    net = build(card["architecture"], len(card["classes"]))
    net.load_state_dict(load_file(path))
    return net.eval(), card


def same_weights(a, b):
    import torch
    from safetensors.torch import load_file

    from fringe.nets import build

    ta, tb = load_file(a), load_file(b)
    check(ta.keys() == tb.keys(), "different tensors")
    diff = max((ta[k].double() - tb[k].double()).abs().max().item() for k in ta)
    card = json.loads(Path(a).with_suffix(".json").read_text())
    torch.manual_seed(card["training"]["seed"])
    init = build(card["architecture"], len(card["classes"])).state_dict()
    moved = max((ta[k].double() - init[k].double()).abs().max().item() for k in ta)
    check(diff <= 1e-5, f"the weights differ by up to {diff}")
    check(moved > 1e-4, f"training moved the weights by {moved} only")
    print(json.dumps({"max_difference": diff, "moved": moved}))


def torch_vs_fringe(model_path, run_dir, predictions_csv):
    import csv

    import torch

    net, card = load_net(model_path)
    run = fringe.Run(run_dir)
    t = run.training_labels()
    x = run.inputs(size=card["input_size"], colour=card["colour"], indices=t["index"])
    with torch.no_grad():
        force, logits, contact = net(torch.from_numpy(x))
    with open(predictions_csv, newline="") as f:
        rows = list(csv.DictReader(f))
    check(len(rows) == len(x), f"fringe eval scored {len(rows)} frames, Python {len(x)}")
    fz = np.array([float(r["fz_pred"]) for r in rows])
    cx = np.array([float(r["contact_pred_x_mm"]) for r in rows])
    cy = np.array([float(r["contact_pred_y_mm"]) for r in rows])
    shapes = [r["shape_pred"] for r in rows]
    diff = max(np.abs(fz - force[:, 2].numpy()).max(), np.abs(cx - contact[:, 0].numpy()).max(),
               np.abs(cy - contact[:, 1].numpy()).max())
    check(diff <= 1e-4, f"fringe's outputs differ from PyTorch's by up to {diff}")
    torch_shapes = [card["classes"][i] for i in logits.argmax(1).tolist()]
    agree = sum(a == b for a, b in zip(shapes, torch_shapes)) / len(shapes)
    check(agree == 1.0, f"shapes agree on {agree:.3f} of the frames")
    # The same model through the package (fringe's backend, from Python).
    m = fringe.Model(model_path)
    p = m.predict(x)
    d2 = np.abs(p["fz"] - force[:, 2].numpy()).max()
    check(d2 <= 1e-4, f"fringe.Model's Fz differs from PyTorch's by {d2}")
    print(json.dumps({"frames": len(rows), "max_difference": float(diff)}))


def bad_card(model_path):
    try:
        fringe.Model(model_path)
    except fringe.ModelError as e:
        print(json.dumps({"message": str(e)}))
        return
    fail(f"{model_path} opened")


def shards(out_dir, *run_dirs):
    import io

    import webdataset as wds
    from PIL import Image

    out_dir = Path(out_dir)
    index = json.loads((out_dir / "shards.json").read_text())
    urls = [str(out_dir / s["file"]) for s in index["shards"]]
    samples = list(wds.WebDataset(urls, shardshuffle=False, empty_check=False))
    runs = [fringe.Run(r) for r in run_dirs]
    check(len(samples) == sum(len(r) for r in runs) == index["samples"],
          f"{len(samples)} samples read, {index['samples']} in the index, "
          f"{sum(len(r) for r in runs)} frames in the runs")
    k = 0
    for run in runs:
        labels = run.label_arrays()
        trainable = set(int(i) for i in run.training_labels()["index"])
        for i in range(len(run)):
            s = samples[k]
            k += 1
            meta = json.loads(s["json"])
            check(meta["run_id"] == run.run_id and meta["index"] == i, f"sample {s['__key__']}: {meta['index']}")
            with Image.open(io.BytesIO(s["png"])) as im:
                check(np.array_equal(np.asarray(im), run.frame(i)), f"sample {s['__key__']}: pixels")
            for col in ("fx", "fz", "mz", "contact_x_mm"):
                want = labels[col][i]
                got = meta[col]
                check((got is None and math.isnan(want)) or got == want, f"sample {s['__key__']}: {col}")
            check(meta["shape"] == labels["shape"][i], f"sample {s['__key__']}: shape")
            check(meta["trainable"] == (i in trainable), f"sample {s['__key__']}: trainable")
            check(meta["pixel_format"] == run.pixel_format, f"sample {s['__key__']}: pixel format")
    sizes = [s["samples"] for s in index["shards"]]
    print(json.dumps({"samples": len(samples), "shards": sizes}))


def dataset(run_dir):
    import torch

    from fringe.torch import Dataset

    run = fringe.Run(run_dir)
    sides = {s: Dataset([run], s, size=64) for s in ("train", "val", "test")}
    t = run.training_labels()
    check(sum(len(d) for d in sides.values()) == len(t["index"]), "the sides hold every labelled frame once")
    presses = {s: set(d.presses) for s, d in sides.items()}
    check(not (presses["train"] & presses["val"]) and not (presses["train"] & presses["test"])
          and not (presses["val"] & presses["test"]), f"a press on two sides: {presses}")
    check(all(len(d) > 0 for d in sides.values()), f"an empty side: {[len(d) for d in sides.values()]}")
    train = sides["train"]
    loader = torch.utils.data.DataLoader(train, batch_size=8, shuffle=True, num_workers=2,
                                         generator=torch.Generator().manual_seed(0))
    batch = next(iter(loader))
    check(batch["input"].shape == (8, 3, 64, 64) and batch["input"].dtype == torch.float32,
          f"batch {batch['input'].shape}")
    # An item is what fringe train trains on: what run.inputs gives for its frame (fringe
    # eval's input), kept as 8-bit grey levels (rounded half away from zero) as fringe train
    # keeps it.
    item = train[3]
    want = run.inputs(size=64, colour="grey", indices=[int(item["frame"])])[0]
    levels = np.clip(np.floor((want * np.float32(0.5) + np.float32(0.5)) * np.float32(255)
                              + np.float32(0.5)), 0, 255).astype(np.uint8)
    kept = levels.astype(np.float32) / np.float32(127.5) - np.float32(1)
    check(np.array_equal(item["input"].numpy(), kept), "an item's input is not run.inputs kept in 8 bits")
    # Made when asked, without the cache, it is the same.
    uncached = Dataset([run], "train", size=64, cache=False)
    check(np.array_equal(uncached[3]["input"].numpy(), kept), "an uncached item differs")
    # The paper's pipelines: ten seeded copies of each frame, each turned with its label.
    aug = Dataset([run], "train", size=64, augment="gray10")
    check(len(aug) == 10 * len(train), f"{len(aug)} copies of {len(train)} frames")
    again = Dataset([run], "train", size=64, augment="gray10")
    k = next(i for i in range(len(train)) if bool(train[i]["in_contact"]))
    copies = [aug[10 * k + c] for c in range(10)]
    check(all(np.array_equal(a["input"].numpy(), b["input"].numpy())
              for a, b in zip(copies, (again[10 * k + c] for c in range(10)))), "copies are not seeded")
    check(not np.array_equal(copies[0]["input"].numpy(), copies[1]["input"].numpy()), "copies are equal")
    # A copy made alone (no cache: its frame decoded for it) is the one made with its frame's
    # other copies, shared by the DataLoader's workers.
    alone = Dataset([run], "train", size=64, augment="gray10", cache=False)
    check(all(np.array_equal(alone[10 * k + c]["input"].numpy(), copies[c]["input"].numpy())
              and np.array_equal(alone[10 * k + c]["contact"].numpy(), copies[c]["contact"].numpy())
              for c in (0, 7)), "a copy made alone differs from the cached one")
    fresh = Dataset([run], "train", size=64, augment="gray10")
    seen = torch.cat([b["input"] for b in torch.utils.data.DataLoader(
        fresh, batch_size=16, shuffle=False, num_workers=2)])
    check(bool(fresh._made.all()), "the workers' inputs did not reach the shared cache")
    check(torch.equal(seen[10 * k:10 * k + 10], torch.stack([c["input"] for c in copies])),
          "the DataLoader's copies differ from the dataset's")
    r0 = float(np.hypot(*train[k]["contact"].numpy()))
    for c in copies:
        r = float(np.hypot(*c["contact"].numpy()))
        check(abs(r - r0) < 1e-4, f"a turned contact is {r} mm from the centre, the label {r0} mm")
    check(len({tuple(np.round(c["contact"].numpy(), 3)) for c in copies}) > 5, "the labels were not turned")
    # fringe train's targets: |Fz| and the turned contact rounded to 0.1 (N, mm), half away
    # from zero, from the recorded values (decimal's ROUND_HALF_UP rounds halves away from 0).
    rounded = Dataset([run], "train", size=64, augment="gray10", targets="rounded")
    for c in (0, 3, 7):
        got, exact = rounded[10 * k + c], copies[c]
        check(torch.equal(got["input"], exact["input"]) and torch.equal(got["force"], exact["force"]),
              "rounded targets changed the input or the force")
        want_fz = _round_tenth(float(t["force"][int(np.flatnonzero(t["index"] == int(got["frame"]))[0])][2]))
        check(float(got["fz"]) == np.float32(want_fz), f"rounded Fz {float(got['fz'])}, want {want_fz}")
    alone_rounded = Dataset([run], "train", size=64, augment="gray10", targets="rounded", cache=False)
    for c in range(10):
        turned = alone._made_now([(k, c)])[1][0]
        want = np.float32([_round_tenth(float(v)) for v in turned])
        check(np.array_equal(alone_rounded[10 * k + c]["contact"].numpy(), want),
              f"copy {c}: rounded contact {alone_rounded[10 * k + c]['contact']}, want {want}")
    rgb = Dataset([run], "train", size=64, augment="rgb3-clean")
    check(len(rgb) == 3 * len(train) and rgb.colour == "rgb", "rgb3-clean")
    print(json.dumps({"train": len(train), "val": len(sides["val"]), "test": len(sides["test"]),
                      "presses": len(presses["train"])}))


def _round_tenth(v):
    """``v`` to 0.1, halves away from zero, computed in decimal from the float's exact value."""
    from decimal import ROUND_HALF_UP, Decimal

    return float(Decimal(v * 10.0).quantize(Decimal(1), rounding=ROUND_HALF_UP)) / 10.0


def reference(ds_dir):
    import csv

    import torch

    from fringe.torch import Dataset, Source

    with open(Path(ds_dir) / "0.labels.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    source = Source(ds_dir)
    t = source.training_labels()
    check(len(source) == len(rows) == len(t["index"]), f"{len(source)} frames of {len(rows)} rows")
    check(source.variant == "layered" and source.profile is not None, "the dataset's design and profile")
    for i, row in enumerate(rows):
        check(abs(t["force"][i][2] - abs(float(row["Fz"]))) < 1e-9, f"row {i}: Fz {t['force'][i][2]} for {row['Fz']}")
        if t["shape"][i] != "None":
            check(t["shape"][i] == row["Indentor_Shape"], f"row {i}: shape {t['shape'][i]}")
            c = (float(row["X_Position_mm"]), float(row["Y_Position_mm"]))
            check(np.allclose(t["contact_mm"][i], c, atol=1e-9), f"row {i}: contact {t['contact_mm'][i]} for {c}")
    sides = {s: Dataset([ds_dir], s, size=64) for s in ("train", "val", "test")}
    frames = sorted(int(f) for d in sides.values() for f in d.frame)
    check(frames == list(range(len(rows))), "the sides do not hold every row once")
    check(all(len(d) > 0 for d in sides.values()), f"an empty side: {[len(d) for d in sides.values()]}")
    x = sides["train"][0]["input"]
    levels = (x + 1) * 127.5
    check(torch.allclose(levels, levels.round(), atol=1e-3), "inputs are not kept 8-bit levels")
    alone = Dataset([ds_dir], "train", size=64, cache=False)[0]["input"]
    check(torch.equal(alone, x), "an uncached item differs")
    print(json.dumps({"frames": len(rows), "sides": {s: len(d) for s, d in sides.items()}}))


COMMANDS = {
    "same-as-fringe": same_as_fringe,
    "same-run": same_run,
    "refused": refused,
    "damaged": damaged,
    "incomplete": incomplete,
    "eval-figures": eval_figures,
    "for-run": for_run,
    "same-weights": same_weights,
    "torch-vs-fringe": torch_vs_fringe,
    "bad-card": bad_card,
    "shards": shards,
    "dataset": dataset,
    "reference": reference,
}

if __name__ == "__main__":
    COMMANDS[sys.argv[1]](*sys.argv[2:])
