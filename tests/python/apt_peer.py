"""Independent APT peer for tests/tests/apt_peer.rs, built on the PyPI package
thorlabs-apt-protocol (import name thorlabs_apt_protocol).

Reads commands from stdin, one per line, and answers each with one line on stdout:
  pack FUNCTION INT...   -> hex bytes packed by thorlabs_apt_protocol.FUNCTION(*ints)
  unpack HEX             -> the message decoded by thorlabs_apt_protocol.Unpacker, as
                            space-separated key=value pairs (bools true/false, lists comma-joined)
A command that fails answers `error <reason>`.
"""
import sys

try:
    import thorlabs_apt_protocol as apt
except ImportError as e:  # the Rust test turns this into a failure telling the user what to run
    print(f"cannot import thorlabs_apt_protocol ({e}); run scripts/test to install the Python test peers",
          file=sys.stderr)
    sys.exit(3)


def fmt(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, bytes):
        return v.split(b"\x00", 1)[0].decode("ascii", "replace").strip()
    if isinstance(v, (list, tuple)):
        return ",".join(fmt(x) for x in v)
    return str(v)


def handle(line):
    words = line.split()
    if words[0] == "pack":
        fn = getattr(apt, words[1])
        return fn(*[int(w, 0) for w in words[2:]]).hex(" ")
    if words[0] == "unpack":
        unpacker = apt.Unpacker()
        unpacker.feed(bytes.fromhex("".join(words[1:])))
        msg = next(unpacker)
        return " ".join(f"{k}={fmt(v)}" for k, v in msg._asdict().items())
    raise ValueError(f"unknown command {words[0]}")


for line in sys.stdin:
    line = line.strip()
    if not line:
        continue
    try:
        print(handle(line))
    except Exception as e:  # reported to the Rust side, which fails the test
        print(f"error {type(e).__name__}: {e}".replace("\n", " "))
    sys.stdout.flush()
