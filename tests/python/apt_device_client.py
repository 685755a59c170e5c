"""Drives an emulated APT stepper controller on a serial port with the independent PyPI client
thorlabs-apt-device (KST101-style: USB unit address, update messages with its own keep-alive).

usage: apt_device_client.py PORT TARGET_STEPS VELOCITY ACCELERATION   (device units)

Prints key=value lines: homed, position, moving, channel_enabled, updates (status update
messages the client received). Exits non-zero with a message on any timeout.
"""
import sys
import time

try:
    from thorlabs_apt_device.devices.aptdevice_motor import APTDevice_Motor
    from thorlabs_apt_device.enums import EndPoint
except ImportError as e:
    sys.exit(
        f"thorlabs-apt-device is missing ({e}); run scripts/test to install "
        "tests/python/requirements.txt into .venv"
    )


def wait(what, cond, timeout, dev):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return
        time.sleep(0.01)
    sys.exit(f"timed out after {timeout} s waiting for {what}; last status: {dev.status_[0][0]}")


def main():
    port, target, vel, acc = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    start = time.monotonic()
    dev = APTDevice_Motor(
        serial_port=port,
        controller=EndPoint.USB,
        bays=(EndPoint.USB,),
        channels=(1,),
        status_updates="auto",
        home=False,
    )
    # The client's read loop only yields to its keep-alive timer when a read times out; with
    # its 0.1 s port timeout and a controller sending a status every 100 ms it may never time
    # out, the keep-alive starves and the controller stops the updates. A shorter timeout
    # keeps the keep-alive going.
    dev._port.timeout = 0.02
    seen = {"updates": 0}
    original = dev._process_message

    def counting(m):
        if m.msg == "mot_get_statusupdate":
            seen["updates"] += 1
        original(m)

    dev._process_message = counting
    status = dev.status_[0][0]
    wait("the first status update message", lambda: status["msgid"] == 0x0481, 3.0, dev)
    dev.identify(channel=None)
    dev.set_enabled(True)
    dev.set_velocity_params(acceleration=acc, max_velocity=vel)
    wait(
        "the velocity parameters read back",
        lambda: dev.velparams_[0][0]["max_velocity"] == vel
        and dev.velparams_[0][0]["acceleration"] == acc,
        2.0,
        dev,
    )
    dev.set_home_params(velocity=vel, offset_distance=0)
    wait(
        "the home parameters read back",
        lambda: dev.homeparams_[0][0].get("home_velocity") == vel,
        2.0,
        dev,
    )
    dev.home()
    wait("homing to finish", lambda: status["homed"] and not status["homing"], 5.0, dev)
    dev.move_absolute(target)
    wait(
        f"the move to {target}",
        lambda: status["position"] == target
        and not (status["moving_forward"] or status["moving_reverse"]),
        5.0,
        dev,
    )
    # Keep the connection (and the client's keep-alive) running past 2.5 s.
    while time.monotonic() - start < 2.8:
        time.sleep(0.05)
    print(f"homed={status['homed']}")
    print(f"position={status['position']}")
    print(f"moving={status['moving_forward'] or status['moving_reverse']}")
    print(f"channel_enabled={status['channel_enabled']}")
    print(f"updates={seen['updates']}")
    sys.stdout.flush()
    dev.close()
    time.sleep(0.3)


if __name__ == "__main__":
    main()
