"""Writes the hand-designed y-stage traces under tests/traces/ystage/ (run from the repo root).

Each scenario is a list of (request, reply) written out as a commented trace; CRCs and MBAP
headers are computed here, independently of fringe's codec. Re-run after editing a scenario.
"""

import struct


def crc16(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def read(start, count):
    return struct.pack(">BHH", 3, start, count)


def read_reply(values):
    return struct.pack(">BB", 3, 2 * len(values)) + b"".join(struct.pack(">H", v & 0xFFFF) for v in values)


def write_multi(start, values):
    return struct.pack(">BHHB", 16, start, len(values), 2 * len(values)) + b"".join(
        struct.pack(">H", v & 0xFFFF) for v in values)


def write_multi_reply(start, values):
    return struct.pack(">BHH", 16, start, len(values))


def write_single(addr, value):
    return struct.pack(">BHH", 6, addr, value)


def exception(fc, code):
    return bytes([fc | 0x80, code])


def hexs(b):
    return " ".join(f"{x:02X}" for x in b)


def words32(v):
    v &= 0xFFFFFFFF
    return [v >> 16, v & 0xFFFF]


def write_trace(name, header_comment, endpoint, framing, steps, slave=1):
    lines = ["# fringe-trace 1", "# device: ystage", f"# endpoint: {endpoint}", "# kind: stream"]
    lines += ["# " + c for c in header_comment]
    t = 0.0
    tid = 0
    for req, rep, comment in steps:
        tid += 1
        if framing == "rtu":
            fr = bytes([slave]) + req
            fr += struct.pack("<H", crc16(fr))
        else:
            fr = struct.pack(">HHHB", tid, 0, len(req) + 1, slave) + req
        lines.append(f"{t:12.6f} > {hexs(fr)}  # {comment}")
        t += 0.004
        if rep is not None:
            if framing == "rtu":
                fr = bytes([slave]) + rep
                fr += struct.pack("<H", crc16(fr))
            else:
                fr = struct.pack(">HHHB", tid, 0, len(rep) + 1, slave) + rep
            lines.append(f"{t:12.6f} < {hexs(fr)}")
        t += 0.020
    with open(f"tests/traces/ystage/{name}.trace", "w") as f:
        f.write("\n".join(lines) + "\n")


# oriental-az: direct data block 0x0058..0x0065 (data number, type, position, speed, accel,
# decel, current), then trigger 0x0066.
def az_block(op_type, steps):
    return ([0, 0] + [0, op_type] + words32(steps) + words32(1000) + words32(10000) + words32(10000)
            + words32(1000))


write_trace(
    "az-tcp-move",
    ["Oriental AZ over Modbus TCP: absolute move to 2.5 mm (500 steps at 200 steps/mm).",
     "Direct data written in one write-multiple, then the trigger; the stage reports MOVE once,",
     "then READY at the target."],
    "tcp 192.168.0.20:502", "tcp",
    [
        (write_multi(0x0058, az_block(1, 500)), write_multi_reply(0x0058, az_block(1, 500)),
         "direct data: data no 0, type 1 (absolute), position 500, speed 1000 Hz, accel/decel 10000, current 100 %"),
        (write_multi(0x0066, [0, 1]), write_multi_reply(0x0066, [0, 1]), "trigger = 1"),
        (read(0x007E, 2), read_reply([0, 0x2000]), "status: MOVE"),
        (read(0x0120, 2), read_reply([0, 200]), "feedback position 200 steps"),
        (read(0x007E, 2), read_reply([0, 0x4020]), "status: READY, IN-POS"),
        (read(0x0120, 2), read_reply([0, 500]), "feedback position 500 steps = 2.5 mm"),
    ])

write_trace(
    "az-tcp-alarm",
    ["Oriental AZ over Modbus TCP: absolute move to 1 mm; the first status poll shows ALM-A,",
     "so the driver must fail naming the alarm bit."],
    "tcp 192.168.0.20:502", "tcp",
    [
        (write_multi(0x0058, az_block(1, 200)), write_multi_reply(0x0058, az_block(1, 200)), "direct data, position 200"),
        (write_multi(0x0066, [0, 1]), write_multi_reply(0x0066, [0, 1]), "trigger = 1"),
        (read(0x007E, 2), read_reply([0, 0x0080]), "status: ALM-A"),
        (read(0x0120, 2), read_reply([0, 37]), "feedback position 37 steps"),
    ])

write_trace(
    "az-tcp-timeout",
    ["Oriental AZ over Modbus TCP: a status read that is never answered (wrong unit id, cable",
     "pulled...): the driver must time out naming the request."],
    "tcp 192.168.0.20:502", "tcp",
    [
        (read(0x007E, 2), None, "status read, no reply"),
    ])

# leadshine-pr: path 0 block 0x6200..0x6205 (mode, position hi/lo, speed rpm, accel, decel ms/1000rpm).
LS_SPEED, LS_ACC = 60, 1667
write_trace(
    "leadshine-rtu-move",
    ["Leadshine PR mode over Modbus RTU (38400 8N1, slave 1): relative move by +0.5 mm from 1 mm",
     "(2000 pulses/mm). The driver reads the position first, writes path 0 as relative (0x0041)",
     "with delta 1000 pulses, runs it with 0x6002 = 0x10 and polls until running clears."],
    "serial /dev/ttyUSB1", "rtu",
    [
        (read(0x1003, 1), read_reply([0x0002]), "motion status: enabled"),
        (read(0x602A, 2), read_reply([0, 2000]), "position 2000 pulses = 1 mm"),
        (write_multi(0x6200, [0x41, 0, 1000, LS_SPEED, LS_ACC, LS_ACC]),
         write_multi_reply(0x6200, [0] * 6), "path 0: relative, +1000 pulses, 60 rpm, 1667 ms/1000rpm"),
        (write_single(0x6002, 0x10), write_single(0x6002, 0x10), "run path 0"),
        (read(0x1003, 1), read_reply([0x0006]), "enabled, running"),
        (read(0x602A, 2), read_reply([0, 2400]), "2400 pulses"),
        (read(0x1003, 1), read_reply([0x0032]), "enabled, command completed, path completed"),
        (read(0x602A, 2), read_reply([0, 3000]), "3000 pulses = 1.5 mm"),
    ])

write_trace(
    "leadshine-rtu-exception",
    ["Leadshine PR mode over Modbus RTU: the drive answers the path write with exception 02",
     "(illegal data address), as a drive without PR mode would."],
    "serial /dev/ttyUSB1", "rtu",
    [
        (write_multi(0x6200, [0x01, 0, 2000, LS_SPEED, LS_ACC, LS_ACC]), exception(16, 2),
         "path 0: absolute to 2000 pulses; refused"),
    ])
