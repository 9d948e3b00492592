"""NumPy ``.npz`` archives read without trusting them, and written back member by member.

An ``.npz`` (``np.savez``, ``np.savez_compressed``) is a zip of ``.npy`` files. Reading
checks every member before any array is made: a zip that is not one, a member whose
declared size exceeds :data:`MAX_EXPANSION` times the archive's own size (a zip bomb), an
``.npy`` header that does not parse, an array whose shape does not match its bytes, and an
array of Python objects (which ``np.load`` would unpickle, running code) are refused with
one line. Memory therefore follows the file's size, never a header's claim.

Writing keeps the archive as it was: the same members in the same order, with the same
names, dates and compression; a member whose array did not change keeps its ``.npy``
bytes, a changed one is written with its original dtype, shape and memory order.
"""

from __future__ import annotations

import io as _io
import re
import struct
import zipfile
import zlib
from dataclasses import dataclass

import numpy as np

from ..core.errors import MotionError

#: The declared (uncompressed) size of all members may be at most this many times the
#: archive's size, plus :data:`EXPANSION_SLACK` bytes: a long take held in one pose
#: compresses far better than 100 times (100,000 frames of a static SMPL pose: 60 MB of
#: arrays in 287 kB), and a gibibyte of arrays is no threat to any machine that cleans it.
MAX_EXPANSION = 100
EXPANSION_SLACK = 1 << 30
#: Longest ``.npy`` header read (numpy's own default limit).
MAX_HEADER = 10000


@dataclass(frozen=True, eq=False)
class Member:
    """One archive member: its zip entry, its ``.npy`` bytes and the array they hold
    (None for a member that is not an ``.npy`` file, carried as bytes)."""

    info: zipfile.ZipInfo
    data: bytes | memoryview
    array: np.ndarray | None

    @property
    def key(self) -> str:
        """The name ``np.load`` gives it (``.npy`` removed)."""
        name = self.info.filename
        return name[:-4] if name.endswith(".npy") else name


def _npy_array(data: bytes | memoryview, name: str, path) -> np.ndarray:
    stream = _io.BytesIO(data)
    try:
        version = np.lib.format.read_magic(stream)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(
                stream, max_header_size=MAX_HEADER
            )
        elif version == (2, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(
                stream, max_header_size=MAX_HEADER
            )
        else:
            raise ValueError(f"unsupported .npy version {version[0]}.{version[1]}")
    except (ValueError, SyntaxError, TypeError, EOFError) as error:
        # (numpy's words, but not its parser's objects: "<ast.Call object at 0x7f...>")
        said = re.sub(r"<[^<>]* object at 0x[0-9a-f]+>", "an expression", str(error))[:120]
        raise MotionError(f"member {name!r}: not a .npy array ({said})", path) from None
    if dtype.hasobject:
        raise MotionError(
            f"member {name!r} holds Python objects (a pickled array); not read, as unpickling "
            "can run code",
            path,
        )
    if any(n < 0 for n in shape):
        raise MotionError(
            f"member {name!r}: {shape} is not an array shape (a negative dimension)", path
        )
    count = 1
    for n in shape:
        count *= int(n)
    body = memoryview(data)[stream.tell() :]
    if count * dtype.itemsize != len(body):
        raise MotionError(
            f"member {name!r}: shape {shape} of {dtype} needs {count * dtype.itemsize} bytes, "
            f"the member has {len(body)}",
            path,
        )
    array = np.frombuffer(body, dtype=dtype, count=count)
    return array.reshape(shape, order="F" if fortran else "C")


def _stored(data: bytes, info: zipfile.ZipInfo) -> memoryview | None:
    """The bytes of an uncompressed member (np.savez) as a view of the archive's bytes (no
    copy), checked against its CRC-32; None for a compressed member."""
    if info.compress_type != zipfile.ZIP_STORED or info.flag_bits & 0x1:  # (0x1: encrypted)
        return None
    at = info.header_offset
    if data[at : at + 4] != b"PK\x03\x04":
        raise zipfile.BadZipFile(f"no local header for {info.filename!r}")
    name_length, extra_length = struct.unpack_from("<HH", data, at + 26)
    start = at + 30 + name_length + extra_length
    body = memoryview(data)[start : start + info.compress_size]
    if len(body) != info.compress_size or zlib.crc32(body) != info.CRC:
        raise zipfile.BadZipFile(f"bad CRC-32 or size for {info.filename!r}")
    return body


def read_npz(data: bytes, path) -> list[Member]:
    """The members of an ``.npz`` archive's bytes, in archive order (see the module)."""
    try:
        archive = zipfile.ZipFile(_io.BytesIO(data))
        infos = archive.infolist()
        declared = sum(info.file_size for info in infos)
        if declared > MAX_EXPANSION * len(data) + EXPANSION_SLACK:
            raise MotionError(
                f"the archive declares {declared:,} bytes of arrays in {len(data):,} bytes, "
                f"more than {MAX_EXPANSION} times its size and over 1 GiB; refused (a zip "
                "bomb?)",
                path,
            )
        names = [info.filename for info in infos]
        if len(set(names)) != len(names):
            raise MotionError("the archive holds two members of the same name", path)
        members = []
        for info in infos:
            if info.is_dir():
                raise MotionError(f"member {info.filename!r} is a folder, not an array", path)
            body: bytes | memoryview | None = _stored(data, info)
            if body is None:  # compressed (np.savez_compressed): inflated, to its size
                with archive.open(info) as stream:
                    body = stream.read(info.file_size + 1)
            if len(body) != info.file_size:
                raise MotionError(
                    f"member {info.filename!r}: size differs from the one declared", path
                )
            array = (
                _npy_array(body, info.filename, path) if info.filename.endswith(".npy") else None
            )
            members.append(Member(info, body, array))
    except MotionError:
        raise
    except (
        zipfile.BadZipFile,
        zipfile.LargeZipFile,
        EOFError,
        OSError,
        ValueError,
        NotImplementedError,
    ) as error:
        raise MotionError(
            f"not a readable .npz archive (a zip of .npy arrays): {str(error)[:120]}", path
        ) from None
    if not any(member.array is not None for member in members):
        raise MotionError("no .npy array in the archive", path)
    return members


def npy_bytes(array: np.ndarray, like: np.ndarray) -> bytes:
    """``array`` as ``.npy`` bytes with the dtype, shape and memory order of ``like``."""
    out = _io.BytesIO()
    fortran = like.flags.f_contiguous and not like.flags.c_contiguous
    values = np.asarray(array).astype(like.dtype, copy=False).reshape(like.shape)
    np.lib.format.write_array(
        out, np.asfortranarray(values) if fortran else values, allow_pickle=False
    )
    return out.getvalue()


def write_npz(members: list[Member], changed: dict[str, np.ndarray]) -> bytes:
    """An archive of ``members`` in order, those named in ``changed`` (by key) holding the
    new arrays (cast to the member's dtype and shape), the others their bytes as read."""
    out = _io.BytesIO()
    with zipfile.ZipFile(out, "w", allowZip64=True) as archive:
        for member in members:
            old = member.info
            info = zipfile.ZipInfo(old.filename, date_time=old.date_time)
            info.compress_type = old.compress_type
            info.external_attr = old.external_attr
            info.create_system = old.create_system
            new = changed.get(member.key)
            body = (
                member.data if new is None or member.array is None else npy_bytes(new, member.array)
            )
            archive.writestr(info, body)
    return out.getvalue()
