"""The glTF container: GLB chunks, the JSON document, buffers and accessors, and the
files (buffers, images) a document refers to by URI."""

from __future__ import annotations

import base64
import binascii
import json
import os
import stat
import struct
from pathlib import Path
from typing import NoReturn
from urllib.parse import unquote, urlsplit

import numpy as np

from ...core.checks import MAX_MAGNITUDE
from ...core.errors import MotionError
from ..files import read_regular_file

GLB_MAGIC = b"glTF"


#: Suffixes of binary glTF files (a VRM animation, ``.vrma``, is one).
GLB_SUFFIXES = (".glb", ".vrma")


#: The extension that makes a GLB a VRM animation: it maps nodes to humanoid bones.
VRM_ANIMATION = "VRMC_vrm_animation"


JSON_CHUNK = 0x4E4F534A


BIN_CHUNK = 0x004E4942


#: Component types: numpy dtype and the divisor of normalized integers (glTF 2.0 3.11).
COMPONENTS = {
    5120: (np.int8, 127.0),
    5121: (np.uint8, 255.0),
    5122: (np.int16, 32767.0),
    5123: (np.uint16, 65535.0),
    5125: (np.uint32, None),
    5126: (np.float32, None),
}


WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def fail(message: str, path) -> NoReturn:
    raise MotionError(message, path)


def read_chunks(data: bytes, path) -> tuple[dict, bytes | None]:
    """The JSON and binary chunks of a GLB."""
    if len(data) < 20:
        fail("a GLB shorter than its header", path)
    magic, version, length = struct.unpack_from("<4sII", data)
    if magic != GLB_MAGIC:
        fail("not a GLB file (no 'glTF' magic)", path)
    if version != 2:
        fail(f"glTF version {version}; only glTF 2.0 is read", path)
    if length != len(data):
        fail(f"the header says {length} bytes, the file has {len(data)}", path)
    at, chunks = 12, []
    while at < len(data):
        if at + 8 > len(data):
            fail("a chunk header runs past the end of the file", path)
        size, kind = struct.unpack_from("<II", data, at)
        if at + 8 + size > len(data):
            fail("a chunk runs past the end of the file", path)
        chunks.append((kind, data[at + 8 : at + 8 + size]))
        at += 8 + size
    if not chunks or chunks[0][0] != JSON_CHUNK:
        fail("the first chunk of a GLB must be JSON", path)
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == BIN_CHUNK else None
    return parse_json(chunks[0][1], path), binary


def parse_json(text: bytes, path) -> dict:
    try:
        document = json.loads(text.decode("utf-8").removeprefix("\ufeff"))
    except UnicodeDecodeError:
        fail("the glTF JSON is not UTF-8 text", path)
    except RecursionError:
        fail("the glTF JSON is nested too deeply", path)
    except ValueError as error:
        fail(f"the glTF JSON does not parse: {str(error)[:100]}", path)
    if not isinstance(document, dict):
        fail("the glTF JSON is not an object", path)
    version = (
        document.get("asset", {}).get("version")
        if isinstance(document.get("asset"), dict)
        else None
    )
    if not isinstance(version, str) or not version.startswith("2."):
        fail(f"asset.version is {version!r}; only glTF 2.0 is read", path)
    return document


def items_of(document: dict, key: str, path) -> list:
    value = document.get(key, [])
    if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
        fail(f"{key!r} is not a list of objects", path)
    return value


def _json_text(value) -> str:
    """``value`` as its JSON writes it, cut to 20 characters (``"24"``: the string)."""
    text = json.dumps(value)[:20]
    return f"the string {text}" if isinstance(value, str) else text


def index_of(value, size: int, what: str, path) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value < size:
        fail(f"{what}: {_json_text(value)} is not an index below {size}", path)
    return value


def _count(value, what: str, path) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        fail(f"{what}: {_json_text(value)} is not a count", path)
    return value


class Buffers:
    """The bytes of each buffer, read when first asked for (GLB chunk, data URI or a file
    beside the glTF)."""

    def __init__(self, document: dict, binary: bytes | None, path):
        self.specs = items_of(document, "buffers", path)
        self.binary = binary
        self.path = path
        self.loaded: dict[int, bytes] = {}

    def __getitem__(self, index: int) -> bytes:
        if index not in self.loaded:
            self.loaded[index] = self._load(index)
        return self.loaded[index]

    def _load(self, index: int) -> bytes:
        spec = self.specs[index]
        length = _count(spec.get("byteLength"), f"buffers[{index}].byteLength", self.path)
        uri = spec.get("uri")
        if uri is None:
            if index != 0 or self.binary is None:
                fail(f"buffers[{index}] has no uri and no GLB binary chunk", self.path)
            data = self.binary
        elif not isinstance(uri, str):
            fail(f"buffers[{index}].uri is not text", self.path)
        elif uri.startswith("data:"):
            head, comma, payload = uri.partition(",")
            if not comma or not head.endswith(";base64"):
                fail(f"buffers[{index}]: a data URI that is not base64", self.path)
            try:
                data = base64.b64decode(payload, validate=True)
            except (binascii.Error, ValueError):
                fail(f"buffers[{index}]: its base64 data does not decode", self.path)
        else:
            data = self._file(index, uri)
        if len(data) < length:
            fail(f"buffers[{index}] holds {len(data)} bytes, byteLength says {length}", self.path)
        return data

    def _file(self, index: int, uri: str) -> bytes:
        what = f"buffers[{index}]"
        return read_referenced(self.path, what, _beside(self.path, what, uri), "a buffer")


def _beside(path, what: str, uri: str) -> Path:
    """The file a relative ``uri`` (of ``what``: ``images[0]``) names in the folder of the
    glTF at ``path``, its symbolic links resolved; its query and fragment (``?v=2``) are no
    part of the name. Refused (one-line MotionError) when it names no file, is a URL or an
    absolute path, climbs out by ``..``, holds a NUL byte, or leads out of the folder
    through a link: ``skin.png -> /etc/passwd`` would put that file into the output."""
    said = f"{what}: uri {uri[:60]!r}"
    parts = _split(uri)
    if parts is None:
        fail(f"{said} is not a valid URI", path)
    name = unquote(parts.path)
    if not name or name.endswith("/"):
        fail(f"{said} names no file", path)
    if not relative_file(uri):
        fail(f"{said} is a URL or an absolute path, not a file beside the glTF", path)
    if ".." in Path(name).parts:
        fail(f"{said} climbs out of the glTF's folder ('..')", path)
    if "\0" in name:
        fail(f"{said} holds a NUL byte", path)
    folder = Path(os.path.realpath(Path(path).parent))
    where = Path(os.path.realpath(folder / name))
    if not where.is_relative_to(folder):
        fail(f"{said} links outside the glTF's folder", path)
    return where


def _split(uri: str):
    """``urlsplit(uri)``, or None where ``uri`` is no valid URI (``//[skin.png``)."""
    try:
        return urlsplit(uri)
    except ValueError:
        return None


def read_referenced(path, what: str, where: Path, kind: str) -> bytes:
    """The bytes of ``where``, a file of ``what`` beside the glTF at ``path``
    (:func:`_beside`); errors name both (``kind`` of file: "is a directory, not an image")."""
    try:
        data, _ = read_regular_file(where, kind)
    except MotionError as error:
        fail(f"{what}: {error.message} ({where})", path)
    return data


def read_accessor(document: dict, buffers: Buffers, index: object, path) -> np.ndarray:
    """``(count, width)`` float64 values of accessor ``index`` (normalized integers
    divided out)."""
    accessors = items_of(document, "accessors", path)
    index = index_of(index, len(accessors), "accessor", path)
    spec = accessors[index]
    where = f"accessors[{index}]"
    if "sparse" in spec:
        fail(f"{where}: sparse accessors are not read", path)
    kind = spec.get("componentType")
    if kind not in COMPONENTS:
        fail(f"{where}: componentType {str(kind)[:12]} is not a glTF component type", path)
    dtype, divisor = COMPONENTS[kind]
    width = WIDTHS.get(spec.get("type"))
    if width is None:
        fail(f"{where}: type {str(spec.get('type'))[:12]!r} is not read", path)
    count = _count(spec.get("count"), f"{where}.count", path)
    views = items_of(document, "bufferViews", path)
    if "bufferView" not in spec:
        return (
            np.zeros((count, width)) if count <= 1 << 16 else fail(f"{where}: no bufferView", path)
        )
    view = views[index_of(spec["bufferView"], len(views), f"{where}.bufferView", path)]
    if view.get("extensions"):
        fail(f"{where}: compressed data ({str(view['extensions'])[:60]}) is not read", path)
    buffer_index = index_of(
        view.get("buffer"), len(buffers.specs), f"{where}: bufferView.buffer", path
    )
    item = np.dtype(dtype).itemsize
    stride = view.get("byteStride", width * item) or width * item
    view_offset = _count(view.get("byteOffset", 0), f"{where}: bufferView.byteOffset", path)
    view_length = _count(view.get("byteLength"), f"{where}: bufferView.byteLength", path)
    offset = _count(spec.get("byteOffset", 0), f"{where}.byteOffset", path)
    stride = _count(stride, f"{where}: byteStride", path)
    needed = offset + (stride * (count - 1) + width * item if count else 0)
    if stride < width * item or needed > view_length:
        fail(f"{where}: {count} elements do not fit in their bufferView", path)
    data = buffers[buffer_index]
    if view_offset + view_length > len(data):
        fail(f"{where}: its bufferView runs past the end of buffer {buffer_index}", path)
    raw = np.frombuffer(data, dtype=np.uint8, count=needed, offset=view_offset)
    start = raw[offset:]
    values = np.lib.stride_tricks.as_strided(
        start[: max(needed - offset, 0)].view(np.uint8),
        shape=(count, width * item),
        strides=(stride, 1),
    )
    out = np.ascontiguousarray(values).view(np.dtype(dtype).newbyteorder("<")).reshape(count, width)
    out = out.astype(np.float64)
    if divisor is not None and spec.get("normalized"):
        out = np.maximum(out / divisor, -1.0)
    return out


#: What a node's or key's numbers must be besides finite (larger is no capture).
IN_RANGE = f" of at most {MAX_MAGNITUDE:g} in size"


def file_buffers(document: dict) -> list[int]:
    """The indices of the buffers whose URI names a file (relative to the glTF's folder)."""
    buffers = document.get("buffers", [])
    return [
        index
        for index, buffer in enumerate(buffers)
        if isinstance(buffer.get("uri"), str) and not buffer["uri"].startswith("data:")
    ]


def relative_file(uri: object) -> bool:
    """Whether ``uri`` names a file by a path relative to the glTF's folder (not a data URI,
    a URL with a scheme or host, or an absolute path: those read the same from anywhere)."""
    if not isinstance(uri, str):
        return False
    parts = _split(uri)
    if parts is None:  # no valid URI: no file (a buffer's is refused when it is read)
        return False
    return not (parts.scheme or parts.netloc or os.path.isabs(unquote(parts.path)))


def images_of(document: dict, path) -> list:
    """The ``images`` of ``document`` (``null`` read as none, as its absence)."""
    return [] if document.get("images") is None else items_of(document, "images", path)


#: Media types of images by file suffix, for an image whose ``mimeType`` is not given: PNG
#: and JPEG (glTF 2.0 core), KTX2 (``KHR_texture_basisu``), WebP (``EXT_texture_webp``).
IMAGE_TYPES = {
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".ktx2": "image/ktx2",
    ".webp": "image/webp",
}


def image_files(document: dict, path) -> tuple[dict[int, tuple[Path, str]], list[str]]:
    """The images of the glTF at ``path`` (its ``document``) named by a relative URI that a
    glTF written to another folder carries, by image index: the file (:func:`_beside`,
    whose refusals are raised) and its media type (``mimeType``, else by suffix); and a
    note for each other such image, which keeps its URI there: no file beside the glTF
    (uncopied textures), not a file, or neither a mimeType nor a known suffix (``.tga``)."""
    found, kept = {}, []
    for index, image in enumerate(images_of(document, path)):
        uri = image.get("uri")
        if not relative_file(uri):
            continue
        where = _beside(path, f"images[{index}]", uri)
        suffix = Path(unquote(uri.partition("?")[0].partition("#")[0])).suffix.lower()
        media = image.get("mimeType") or IMAGE_TYPES.get(suffix)
        why = _not_a_file(where)
        if why is None and isinstance(media, str):
            found[index] = where, media
            continue
        why = why or "no mimeType, and no image type by its suffix"
        kept.append(
            f"images[{index}] {uri[:60]!r}: {why}; a glTF written to another folder "
            "keeps this uri, not the image"
        )
    return found, kept


def _not_a_file(where: Path) -> str | None:
    """Why ``where`` is not a regular file to read ("no such file beside the glTF"), or
    None when it is one."""
    try:
        regular = stat.S_ISREG(os.stat(where).st_mode)
    except FileNotFoundError:
        return "no such file beside the glTF"
    except OSError as error:  # (a name too long, a loop of links)
        return f"cannot be read ({error.strerror or error})"
    return None if regular else "not a file (a folder, pipe or device)"


def image_notes(document: dict, path) -> list[str]:
    """What :func:`image_files` notes, said when the glTF is read; or that a glTF written
    from it into another folder is refused, and why (an image leading out of its folder)."""
    try:
        return image_files(document, path)[1]
    except MotionError as error:
        return [f"{error.message}; writing it as glTF to another folder is refused"]


def data_uri(data: bytes, media: str = "application/octet-stream") -> str:
    return f"data:{media};base64," + base64.b64encode(data).decode("ascii")


def glb_bytes(text: bytes, binary: bytes | None) -> bytes:
    text += b" " * (-len(text) % 4)
    chunks = [struct.pack("<II", len(text), JSON_CHUNK), text]
    if binary is not None:
        binary += b"\0" * (-len(binary) % 4)
        chunks += [struct.pack("<II", len(binary), BIN_CHUNK), binary]
    body = b"".join(chunks)
    return struct.pack("<4sII", GLB_MAGIC, 2, 12 + len(body)) + body
