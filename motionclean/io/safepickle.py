"""Pickles read without running their code: numpy arrays and plain containers only.

A pickle names the functions that rebuild its objects, and ``pickle.load`` calls them: a
hostile file can name ``os.system``. :func:`loads` admits only what numbers need: numpy's
array, dtype and scalar constructors (ndarray ``_reconstruct``, ``_frombuffer``,
``scalar``, ``dtype``), ``dict``, ``list``, ``tuple``, ``set``, ``frozenset``,
``OrderedDict`` and ``defaultdict`` (read as plain dicts), ``complex``, ``slice`` and
latin-1 ``_codecs.encode`` (how protocol 2 spells bytes), and joblib's array wrapper
(arrays written by ``joblib.dump`` follow their wrapper as raw bytes). Anything else is
refused with one line naming it, before it is called. Arrays of Python objects are refused
too, and every array's size is checked against the bytes left in the file, so memory
follows the file's size.

Files compressed by ``joblib.dump(..., compress=...)`` (zlib, gzip, bz2, xz/lzma) are
decompressed first, to at most :data:`MAX_EXPANSION` times their size. Pickles written by
Python 2 are read too: their ``str`` (text and arrays' bytes alike) as latin-1, as numpy
asks. A file that does not read as a pickle is refused in words, not Python's exception:
an empty file, one that ends before its pickle does, one that is no pickle.
"""

from __future__ import annotations

import bz2
import io as _io
import lzma
import pickle
import re
import zlib
from typing import Any

import numpy as np

from ..core.errors import MotionError
from ..core.reserve import let_go

#: A compressed pickle may expand to at most this many times its size (plus 1 MiB).
MAX_EXPANSION = 100

_reconstruct = np.zeros(1).__reduce__()[0]  # numpy's ndarray rebuilder, however spelled
_frombuffer = np.zeros(2).__reduce_ex__(5)[0]
_scalar = np.float64(1.0).__reduce__()[0]


class Refused(Exception):
    """A pickle that asks for something other than arrays and containers."""


def _dtype(*args, **kwargs) -> np.dtype:
    dtype = np.dtype(*args, **kwargs)
    if dtype.hasobject:
        raise Refused("an array of Python objects")
    return dtype


class _Sizes:
    """Checks a constructed array against the bytes the file still holds."""

    def __init__(self, limit: int):
        self.limit = limit

    def shape(self, shape, dtype) -> None:
        count = 1
        for n in shape if isinstance(shape, tuple) else (shape,):
            if not isinstance(n, int) or n < 0:
                raise Refused(f"an array shape {shape!r}")
            count *= n
        if count * max(np.dtype(dtype).itemsize, 1) > self.limit:
            raise Refused(f"an array of shape {shape} larger than the file")


def _plain_dict(*args):
    """``defaultdict(factory)`` and ``OrderedDict(...)`` read as a plain dict."""
    return {}


def _latin1(text, encoding="latin1"):
    if encoding not in ("latin1", "latin-1"):
        raise Refused(f"_codecs.encode with {encoding!r}")
    return text.encode("latin1")


class NumpyArrayWrapper:
    """Stand-in for ``joblib.numpy_pickle.NumpyArrayWrapper``: its attributes (subclass,
    shape, order, dtype) say how the raw bytes after it are to be read."""


def _admitted(sizes: _Sizes) -> dict[tuple[str, str], object]:
    def reconstruct(subtype, shape, dtype):
        sizes.shape(shape, np.uint8)
        if subtype is not np.ndarray:
            raise Refused("an array subclass")
        return _reconstruct(np.ndarray, shape, _dtype(dtype))

    def frombuffer(buffer, dtype, shape, order):
        return _frombuffer(buffer, _dtype(dtype), shape, order)

    def scalar(dtype, *data):
        return _scalar(_dtype(dtype), *data)

    table: dict[tuple[str, str], object] = {}
    for core in ("numpy.core", "numpy._core"):
        table[(f"{core}.multiarray", "_reconstruct")] = reconstruct
        table[(f"{core}.multiarray", "scalar")] = scalar
        table[(f"{core}.numeric", "_frombuffer")] = frombuffer
    table[("numpy", "ndarray")] = np.ndarray
    table[("numpy", "memmap")] = np.ndarray  # joblib's wrapper names the array's class
    table[("numpy", "dtype")] = _dtype
    for name, kind in (
        ("dict", dict),
        ("list", list),
        ("tuple", tuple),
        ("set", set),
        ("frozenset", frozenset),
        ("complex", complex),
        ("slice", slice),
    ):
        table[("builtins", name)] = kind
        table[("__builtin__", name)] = kind
    table[("collections", "OrderedDict")] = _plain_dict
    table[("collections", "defaultdict")] = _plain_dict
    table[("_codecs", "encode")] = _latin1
    table[("joblib.numpy_pickle", "NumpyArrayWrapper")] = NumpyArrayWrapper
    table[("sklearn.externals.joblib.numpy_pickle", "NumpyArrayWrapper")] = NumpyArrayWrapper
    return table


#: The Python unpickler (its BUILD can be extended to read joblib's arrays); its internals
#: (``stack``, ``dispatch``) are not in the type stubs.
_PythonUnpickler: Any = pickle._Unpickler


class _Unpickler(_PythonUnpickler):
    dispatch = dict(_PythonUnpickler.dispatch)

    def __init__(self, stream: _io.BytesIO, size: int):
        super().__init__(stream, encoding="latin1")  # (Python 2's str: see the module)
        self.stream = stream
        self.size = size
        self.sizes = _Sizes(size)
        self.admitted = _admitted(self.sizes)

    def find_class(self, module: str, name: str):
        found = self.admitted.get((module, name))
        if found is None:
            raise Refused(f"{module}.{name}")
        return found

    def persistent_load(self, pid):
        raise Refused("a persistent reference")

    def load_build(self) -> None:
        state = self.stack[-1]
        target = self.stack[-2]
        object_array = (
            isinstance(target, np.ndarray)
            and isinstance(state, tuple)
            and len(state) >= 3
            and isinstance(state[2], np.dtype)
            and state[2].hasobject
        )
        if object_array:
            raise Refused("an array of Python objects")
        if isinstance(target, NumpyArrayWrapper):
            self.stack.pop()
            if not isinstance(state, dict):
                raise Refused("a joblib array without its attributes")
            self.stack[-1] = self._joblib_array(state)
            return
        super().load_build()
        if isinstance(target, np.dtype) and target.hasobject:
            raise Refused("an array of Python objects")

    dispatch[pickle.BUILD[0]] = load_build

    def _joblib_array(self, state: dict) -> np.ndarray:
        dtype, shape, order = state.get("dtype"), state.get("shape"), state.get("order", "C")
        if not isinstance(dtype, np.dtype) or not isinstance(shape, tuple):
            raise Refused("a joblib array without dtype and shape")
        if dtype.hasobject:
            raise Refused("an array of Python objects")
        if state.get("numpy_array_alignment_bytes") is not None:
            padding = self.stream.read(1)
            if len(padding) != 1:
                raise EOFError("the file ends inside an array")
            self.stream.read(padding[0])
        self.sizes.shape(shape, dtype)
        count = 1
        for n in shape:
            count *= n
        data = self.stream.read(count * dtype.itemsize)
        if len(data) != count * dtype.itemsize:
            raise EOFError("the file ends inside an array")
        array = np.frombuffer(data, dtype=dtype, count=count)
        if order == "F":
            return array.reshape(shape[::-1]).transpose()
        return array.reshape(shape)


def _decompressed(data: bytes, path) -> bytes:
    """``data`` itself, or its decompression when it starts like a compressed stream."""
    limit = MAX_EXPANSION * len(data) + (1 << 20)
    engine: Any
    if data[:1] == b"\x78":
        kind, engine = "zlib", zlib.decompressobj()
    elif data[:2] == b"\x1f\x8b":
        kind, engine = "gzip", zlib.decompressobj(16 + zlib.MAX_WBITS)
    elif data[:3] == b"BZh":
        kind, engine = "bz2", bz2.BZ2Decompressor()
    elif data[:6] == b"\xfd7zXZ\x00" or data[:3] == b"]\x00\x00":
        kind, engine = "xz", lzma.LZMADecompressor()
    else:
        return data
    try:
        out = engine.decompress(data, limit + 1)
    except (zlib.error, OSError, EOFError, lzma.LZMAError, ValueError):
        raise MotionError(
            f"starts as {kind}-compressed data but does not decompress: damaged or truncated, "
            "or not a pickle",
            path,
        ) from None
    if len(out) > limit:
        raise MotionError(
            f"decompresses to more than {MAX_EXPANSION} times its size; refused", path
        )
    return out


def loads(data: bytes, path) -> object:
    """The object a pickle's bytes hold, admitting only arrays and containers (see the
    module); anything else is a one-line :class:`MotionError`."""
    if not data:
        raise MotionError("empty file", path)
    data = _decompressed(data, path)
    stream = _io.BytesIO(data)
    try:
        return _Unpickler(stream, len(data)).load()
    except Refused as refused:
        if _cut(data) and not _NAME.fullmatch(str(refused)):
            # cut inside an array: its bytes read as opcodes, asking for no class's name
            raise MotionError(_unreadable(EOFError()), path) from None
        raise MotionError(
            f"refused: the pickle asks for {str(refused)[:120]}; only numpy arrays and plain "
            "containers are read (unpickling anything else could run code)",
            path,
        ) from None
    except RecursionError:
        raise MotionError("a pickle nested too deeply", path) from None
    except MemoryError as error:
        let_go(error)  # its frames go with it: the MotionError does not keep them
        raise MotionError("a pickle too large to read", path) from None
    except Exception as error:  # any malformed stream: one line, never a traceback
        raise MotionError(_unreadable(EOFError() if _cut(data) else error), path) from None


#: A class a pickle asks for by name (``module.name``), as against bytes read as one.
_NAME = re.compile(r"[A-Za-z_][\w.]*\.[A-Za-z_]\w*")


def _cut(data: bytes) -> bool:
    """Whether ``data`` starts as a pickle (protocol 2 on) and does not end as one: a
    pickle's last opcode is STOP."""
    return data.startswith(pickle.PROTO) and not data.endswith(pickle.STOP)


def _unreadable(error: Exception) -> str:
    """What a file that does not unpickle is, in words (``error``: what the unpickler
    raised)."""
    if isinstance(error, EOFError) or any(w in str(error) for w in ("truncated", "exhausted")):
        return "the file ends before its pickle does: truncated, or not a pickle"
    return "not a pickle, or a damaged one: its bytes do not read as one"
