"""A simulated Modbus y stage served by pymodbus, the independent peer of fringe's Modbus driver.

    modbus_stage_server.py --profile az|leadshine (--tcp PORT | --serial PATH [--baud N --parity E|N|O])

The stage keeps its registers where the real drive does (Oriental Motor AZ direct data operation,
or Leadshine PR mode, path 0). Writing the trigger start value starts a motion: the feedback
position ramps from where it was to the target over MOVE_SECONDS with the moving bit set, then the
stage reports idle and ready. Every register write the server receives is printed on stdout as

    WRITE <function code> <address> <value> <value> ...

so a test can check what the driver wrote. "SERVING" is printed once the server is configured.
"""

import argparse
import asyncio
import sys
import time

try:
    from pymodbus.server import ModbusSerialServer, ModbusTcpServer
    from pymodbus.simulator import SimData, SimDevice
    from pymodbus.simulator.simdata import DataType
    from pymodbus import FramerType
except ImportError as e:  # pragma: no cover
    print(f"pymodbus is missing ({e}): run scripts/test, which installs tests/python/requirements.txt", file=sys.stderr)
    sys.exit(3)

MOVE_SECONDS = 0.4

PROFILES = {
    # Oriental Motor AZ: 32-bit values, upper word first.
    "az": dict(
        blocks=[(0x0058, 16), (0x007E, 2), (0x0120, 2)],
        mode=(0x005A, 2), absolute=1, relative=2,
        target=0x005C, trigger=(0x0066, 2), start=1, stop=None, home=None,
        status=(0x007E, 2), feedback=0x0120,
        moving=0x2000, ready=0x0020, homed=0x0010,
    ),
    # Leadshine PR mode, path 0.
    "leadshine": dict(
        blocks=[(0x1003, 1), (0x6002, 1), (0x602A, 2), (0x6200, 6)],
        mode=(0x6200, 1), absolute=0x0001, relative=0x0041,
        target=0x6201, trigger=(0x6002, 1), start=0x10, stop=0x40, home=0x20,
        status=(0x1003, 1), feedback=0x602A,
        moving=0x0004, ready=0x0002, homed=0x0040,
    ),
}


def to_i32(hi, lo):
    v = (hi << 16) | lo
    return v - (1 << 32) if v & 0x80000000 else v


class Stage:
    def __init__(self, p):
        self.p = p
        self.position = 0
        self.origin = 0
        self.target = 0
        self.t0 = 0.0
        self.moving = False
        self.homed = False

    def now_position(self):
        if self.moving:
            f = (time.monotonic() - self.t0) / MOVE_SECONDS
            if f >= 1.0:
                self.moving = False
                self.position = self.target
            else:
                self.position = round(self.origin + (self.target - self.origin) * f)
        return self.position

    def start(self, target):
        self.now_position()
        self.origin = self.position
        self.target = target
        self.t0 = time.monotonic()
        self.moving = True

    def stop(self):
        self.target = self.now_position()
        self.moving = False

    async def action(self, fc, start_address, address, count, regs, values):
        p = self.p

        def reg(a):
            return regs[a - start_address]

        def put(a, v):
            regs[a - start_address] = v & 0xFFFF

        if values is not None and fc in (6, 16):
            print("WRITE", fc, address, *values, flush=True)
            trig, words = p["trigger"]
            last = address + len(values) - 1
            if address <= trig + words - 1 and last >= trig:
                # The trigger value is the last register of the trigger field.
                value = values[trig + words - 1 - address] if last >= trig + words - 1 else None
                if value == p["start"]:
                    mode = reg(p["mode"][0] + p["mode"][1] - 1)
                    steps = to_i32(reg(p["target"]), reg(p["target"] + 1))
                    if mode == p["relative"]:
                        self.start(self.now_position() + steps)
                    else:
                        self.start(steps)
                elif p["stop"] is not None and value == p["stop"]:
                    self.stop()
                elif p["home"] is not None and value == p["home"]:
                    self.start(0)
                    self.homed = True
        pos = self.now_position() & 0xFFFFFFFF
        put(p["feedback"], pos >> 16)
        put(p["feedback"] + 1, pos)
        status = p["moving"] if self.moving else p["ready"]
        if self.homed and not self.moving:
            status |= p["homed"]
        saddr, swords = p["status"]
        put(saddr + swords - 1, status)
        return None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--profile", choices=sorted(PROFILES), required=True)
    ap.add_argument("--tcp", type=int)
    ap.add_argument("--serial")
    ap.add_argument("--baud", type=int, default=38400)
    ap.add_argument("--parity", default="N")
    ap.add_argument("--slave", type=int, default=1)
    args = ap.parse_args()
    p = PROFILES[args.profile]
    stage = Stage(p)
    simdata = [SimData(a, count=n, values=0, datatype=DataType.REGISTERS) for a, n in p["blocks"]]
    device = SimDevice(args.slave, simdata=simdata, action=stage.action)

    async def run():
        if args.tcp is not None:
            server = ModbusTcpServer(device, address=("127.0.0.1", args.tcp))
        else:
            server = ModbusSerialServer(
                device, framer=FramerType.RTU, port=args.serial, baudrate=args.baud, parity=args.parity
            )
        print("SERVING", flush=True)
        await server.serve_forever()

    asyncio.run(run())


if __name__ == "__main__":
    main()
