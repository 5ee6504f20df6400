"""A firmware image file, checked before anything runs it, and the build that made it.

``firmware/build`` writes its outputs into a fresh folder with a manifest, ``build.json`` (each
output's sha256 and each image's GNU build id, the *image id* the firmware reports in HELLO), and
switches ``firmware/out/current`` to it in one rename (``firmware/README.md``). This module:

* :func:`check_image` refuses an image that cannot be the firmware (missing, empty, not an ELF, an
  ELF for another machine or cut short, no loadable segment in the MCU's flash) or that is not
  the file its ``build.json`` lists (a changed byte), with one line naming the image, before QEMU
  or a flasher ever sees it;
* :func:`manifest_for` reads the ``build.json`` beside an image (through its links);
* :func:`image_id_warning` says, in one line, when the device runs another image than the
  source tree's last build (``firmware/out/build.json``).
"""
from __future__ import annotations

import hashlib
import json
import struct
from pathlib import Path

from experiments.errors import DisplayError

__all__ = ["BadImage", "check_image", "manifest_for", "image_id_warning", "FLASH_RANGE"]

#: The STM32F405's flash (the linker script's FLASH region): loadable segments live here.
FLASH_RANGE = (0x0800_0000, 0x0810_0000)
_EM_ARM = 40
_ELF_HEAD = struct.Struct("<16sHHIIIIIHHHHHH")
_PHDR = struct.Struct("<IIIIIIII")
_PT_LOAD = 1


class BadImage(DisplayError):
    """The file is not a firmware image this host will run or flash."""


def _refuse(image: Path, why: str) -> BadImage:
    return BadImage(f"firmware image {image}: {why}; not using it")


def check_image(image) -> Path:
    """Check that ``image`` is an ARM ELF executable with its code in the MCU's flash.

    Returns
    -------
    Path
        The image.

    Raises
    ------
    BadImage
        One line naming the image and what is wrong with it.
    """
    image = Path(image)
    try:
        data = image.read_bytes()
    except FileNotFoundError:
        raise _refuse(image, "no such file") from None
    except OSError as exc:
        raise _refuse(image, f"cannot be read ({exc.strerror or exc})") from None
    if not data:
        raise _refuse(image, "the file is empty")
    if data[:4] != b"\x7fELF":
        raise _refuse(image, f"not an ELF file (starts {data[:4].hex(' ')}, expected 7f 45 4c 46; "
                             f"a .bin is flashed, QEMU runs the .elf)")
    if len(data) < _ELF_HEAD.size:
        raise _refuse(image, f"ELF header cut short ({len(data)} bytes)")
    (ident, e_type, machine, _, entry, phoff, _, _, _, phentsize, phnum, _, _, _) = \
        _ELF_HEAD.unpack_from(data)
    if ident[4] != 1 or ident[5] != 1:
        raise _refuse(image, "not a 32-bit little-endian ELF (the STM32F405's)")
    if machine != _EM_ARM or e_type != 2:
        raise _refuse(image, f"not an ARM executable (e_machine {machine}, e_type {e_type})")
    if phentsize != _PHDR.size or phnum == 0 or phoff + phnum * phentsize > len(data):
        raise _refuse(image, f"program headers missing or cut short (file of {len(data)} bytes)")
    lo, hi = FLASH_RANGE
    loads = []
    for i in range(phnum):
        (p_type, offset, _, paddr, filesz, _, _, _) = _PHDR.unpack_from(data, phoff + i * phentsize)
        if p_type != _PT_LOAD or filesz == 0:
            continue
        if offset + filesz > len(data):
            raise _refuse(image, f"segment {i} runs past the end of the file (cut short)")
        loads.append(paddr)
    if not any(lo <= a < hi for a in loads):
        raise _refuse(image, f"no loadable segment in the MCU's flash (0x{lo:08x}–0x{hi:08x})")
    if not lo <= entry < hi:
        raise _refuse(image, f"entry point 0x{entry:08x} is outside the MCU's flash")
    _check_against_manifest(image, data)
    return image


def manifest_for(image) -> dict | None:
    """The ``build.json`` in the folder the image (after its links) lives in, or ``None``.

    ``image`` may also be a ``build.json`` itself."""
    image = Path(image).resolve()
    path = image if image.name == "build.json" else image.parent / "build.json"
    try:
        meta = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return meta if isinstance(meta, dict) else None


def _check_against_manifest(image: Path, data: bytes) -> None:
    meta = manifest_for(image)
    if meta is None:
        return
    entry = meta.get(image.resolve().name)
    want = entry.get("sha256") if isinstance(entry, dict) else None
    if want is None:
        return
    got = hashlib.sha256(data).hexdigest()
    if got != want:
        raise _refuse(image, f"sha256 {got[:16]}… differs from its build.json ({want[:16]}…): "
                             f"changed since it was built (run firmware/build)")


def image_id_warning(build_json, device_image_id: str, port: str) -> str | None:
    """One line when the device's HELLO image id is none of those a ``build.json`` records.

    ``build_json`` is the source tree's last build (``firmware/out/build.json``); no file, no
    warning (nothing is known to compare with).
    """
    path = Path(build_json)
    meta = manifest_for(path)
    if meta is None:
        return None
    ids = {k: v["image_id"] for k, v in meta.items()
           if isinstance(v, dict) and isinstance(v.get("image_id"), str)}
    if not ids or device_image_id in ids.values():
        return None
    known = ", ".join(f"{k} {v[:12]}" for k, v in sorted(ids.items()))
    return (f"warning: display {port}: the device runs image {device_image_id or '(none stated)'}, "
            f"not the source tree's last build ({path.resolve()}: {known}); flash or rebuild")
