"""The thermocue display protocol, the host's side (``docs/display-protocol.md``).

Its wire format -- :mod:`.framing` (frames, CRC) and :mod:`.messages` (commands, codes, payload
layouts, the protocol's constants) -- is what an emulator of the device may import; the rest is
the host: :mod:`.link` (numbered requests, replies, heartbeats), :mod:`.heartbeat` (the helper
process), :mod:`.handshake` (what the host accepts in HELLO; the limits it sends),
:mod:`.upload` (a profile in checked chunks), :mod:`.operator_reset`, :mod:`.driver`
(:class:`~.driver.ThermalDisplay`, the ``serial`` backend, holding a :class:`~.link.ProtocolLink`:
a device path, a pty, a pyserial URL) and :mod:`.qemu_firmware` (``qemu-firmware://``: the C firmware
under QEMU).
"""
