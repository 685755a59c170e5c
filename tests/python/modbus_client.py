"""An independent Modbus TCP client (pymodbus, from PyPI) driving fringe's emulated y stage.

Usage: modbus_client.py PORT

The stage runs the built-in `oriental-az` register map (slave 1). The script does what a user's own
script would: reads the feedback position, writes a direct-data absolute move to 2.5 mm
(500 steps at 200 steps/mm) and the trigger, polls the status register until the MOVE bit drops,
reads the position back, then asks for a register the drive does not have. It prints one JSON
object per line for the Rust test (tests/tests/modbus_emulator.rs):
  {"step": "start", "position": N}
  {"step": "moved", "position": N, "status": S, "polls_moving": K}
  {"step": "input", "position": N}                  (the same register read with function 0x04)
  {"step": "missing", "exception": C}               (C = the Modbus exception code)
"""

import json
import sys
import time

try:
    from pymodbus.client import ModbusTcpClient
except ImportError as e:  # pragma: no cover
    print(f"pymodbus is missing ({e}): run scripts/test, which installs tests/python/requirements.txt", file=sys.stderr)
    sys.exit(3)

FEEDBACK = 0x0120
STATUS = 0x007E
MOVE_BIT = 0x2000


def signed32(regs):
    v = (regs[0] << 16) | regs[1]
    return v - (1 << 32) if v & 0x8000_0000 else v


def ok(response, what):
    if response.isError():
        raise SystemExit(f"{what} failed: {response}")
    return response


def main():
    port = int(sys.argv[1])
    client = ModbusTcpClient("127.0.0.1", port=port, timeout=2)
    if not client.connect():
        raise SystemExit(f"cannot connect to 127.0.0.1:{port}")
    regs = ok(client.read_holding_registers(FEEDBACK, count=2, device_id=1), "read position").registers
    print(json.dumps({"step": "start", "position": signed32(regs)}), flush=True)
    # Data number 0, operation type 1 (absolute), position 500 steps, speed 1000 Hz,
    # acceleration and deceleration 10000, current 100 %.
    block = [0, 0, 0, 1, 0, 500, 0, 1000, 0, 10000, 0, 10000, 0, 1000]
    ok(client.write_registers(0x0058, block, device_id=1), "write direct data")
    ok(client.write_registers(0x0066, [0, 1], device_id=1), "write trigger")
    polls_moving = 0
    deadline = time.monotonic() + 5
    while True:
        status = ok(client.read_holding_registers(STATUS, count=2, device_id=1), "read status").registers
        word = (status[0] << 16) | status[1]
        if not word & MOVE_BIT:
            break
        polls_moving += 1
        if time.monotonic() > deadline:
            raise SystemExit("the stage did not stop within 5 s")
        time.sleep(0.02)
    regs = ok(client.read_holding_registers(FEEDBACK, count=2, device_id=1), "read position").registers
    print(json.dumps({"step": "moved", "position": signed32(regs), "status": word, "polls_moving": polls_moving}), flush=True)
    regs = ok(client.read_input_registers(FEEDBACK, count=2, device_id=1), "read input registers").registers
    print(json.dumps({"step": "input", "position": signed32(regs)}), flush=True)
    missing = client.read_holding_registers(0x0400, count=1, device_id=1)
    print(json.dumps({"step": "missing", "exception": getattr(missing, "exception_code", None)}), flush=True)
    client.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
