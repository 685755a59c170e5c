"""Drives an emulated APT stepper controller on a serial port with pyLabLib's KinesisMotor
(an independent implementation of the Thorlabs APT protocol from PyPI).

usage: apt_pylablib_client.py PORT TARGET_STEPS

Prints key=value lines: model, homed, position, status. Exits non-zero on any error.
"""
import errno
import sys

try:
    from pylablib.devices import Thorlabs
    from pylablib.devices.Thorlabs import kinesis
except ImportError as e:
    sys.exit(f"pylablib is missing ({e}); run scripts/test to install tests/python/requirements.txt")

# pyLabLib pulses RTS at open; a pseudo-terminal has no modem lines and refuses the ioctl
# (ENOTTY), where an FTDI adapter accepts it. Skip the pulse only for that refusal.
_cycle_rts = kinesis.BasicKinesisDevice._cycle_rts


def _cycle_rts_unless_pty(instr):
    try:
        _cycle_rts(instr)
    except OSError as e:
        if e.errno != errno.ENOTTY:
            raise


kinesis.BasicKinesisDevice._cycle_rts = staticmethod(_cycle_rts_unless_pty)


def main():
    port, target = sys.argv[1], int(sys.argv[2])
    motor = Thorlabs.KinesisMotor(("serial", port), scale="step")
    try:
        info = motor.get_device_info()
        print(f"model={info.model_no}")
        motor.home(sync=True, force=True, timeout=5)
        print(f"homed={motor.is_homed()}")
        motor.move_to(target)
        motor.wait_move(timeout=5)
        print(f"position={motor.get_position()}")
        print(f"status={','.join(sorted(motor.get_status()))}")
    finally:
        motor.close()


if __name__ == "__main__":
    main()
