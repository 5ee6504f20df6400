"""The thermocue display protocol, the host's side (``docs/display-protocol.md``).

Its wire format -- :mod:`.framing` (frames, CRC) and :mod:`.messages` (commands, codes, payload
layouts, the protocol's constants) -- is what an emulator of the device may import; the rest is
the host: :mod:`.link` (numbered requests, replies, heartbeats), :mod:`.heartbeat` (the helper
process), :mod:`.driver` (:class:`~.driver.ThermalDisplay`, the ``serial`` backend: a device
path, a pty, a pyserial URL) and :mod:`.qemu_firmware` (``qemu-firmware://``: the C firmware
under QEMU).
"""
