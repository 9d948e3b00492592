"""glTF 2.0 (.glb, .gltf): files written by Blender's exporter read as the BVH they came
from, samplers evaluated as the specification says, and write-back that keeps the file."""

from __future__ import annotations

import base64
import json
import shutil
import struct

import numpy as np
import pytest
from helpers import ROOT, SAMPLE, cut_bvh, run_cli, turned_copy

import motionclean as mc
from motionclean.core import contacts, kinematics, quat

#: Exported by Blender 5.0.1 (glTF I/O 5.0.21) from sample_data/131_02_cut.bvh (CMU 131_02,
#: free to use, see sample_data/README.md): BVH import at 120 fps, glTF export with
#: defaults; 96 frames as GLB, 24 as .gltf + .bin.
BLENDER_GLB = ROOT / "tests" / "data" / "blender" / "131_02_cut.glb"
BLENDER_GLTF = ROOT / "tests" / "data" / "blender" / "131_02_cut.gltf"
#: pixiv/three-vrm's example VRM animation (MIT; tests/data/vrm/README.md).
VRMA = ROOT / "tests" / "data" / "vrm" / "test.vrma"


def glb_parts(path) -> tuple[dict, bytes]:
    data = path.read_bytes()
    size = struct.unpack_from("<I", data, 12)[0]
    binary = data[20 + size + 8 :]
    return json.loads(data[20 : 20 + size]), binary


def relative_world(motion: mc.Motion, names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """World positions and world rotations relative to the first frame, joints by name."""
    positions, rotations = kinematics.forward(motion)
    index = [motion.names.index(name) for name in names]
    rotations = rotations[:, index]
    return positions[:, index], quat.multiply(rotations, quat.conjugate(rotations[:1]))


def degrees(a: np.ndarray, b: np.ndarray) -> float:
    dots = np.clip(np.abs(np.einsum("...i,...i->...", a, b)), 0.0, 1.0)
    return float(np.degrees(2 * np.arccos(dots.min())))


@pytest.fixture(scope="module")
def bvh_96(tmp_path_factory):
    return cut_bvh(SAMPLE, tmp_path_factory.mktemp("gltf") / "cut96.bvh", 96)


def test_blender_export_reads_as_the_bvh_it_came_from(bvh_96):
    glb, bvh = mc.load(BLENDER_GLB), mc.load(bvh_96)
    assert sorted(glb.names) == sorted(bvh.names) and glb.n_frames == 96
    assert glb.frame_rate == 120.0
    assert glb.channels[glb.names.index("Hips")][:3] == ("Xposition", "Yposition", "Zposition")
    p_glb, r_glb = relative_world(glb, bvh.names)
    p_bvh, r_bvh = relative_world(bvh, bvh.names)
    assert np.abs(p_glb - p_bvh).max() < 1e-4  # float32 in the file, 24 units tall
    assert degrees(r_glb, r_bvh) < 0.01
    separate = mc.load(BLENDER_GLTF)
    assert separate.n_frames == 24 and np.array_equal(separate.names, glb.names)
    assert np.abs(separate.rotations - glb.rotations[:24]).max() < 1e-6  # separate exports


def test_untouched_file_is_written_byte_for_byte(tmp_path):
    mc.save(mc.load(BLENDER_GLB), tmp_path / BLENDER_GLB.name)  # any folder: self-contained
    assert (tmp_path / BLENDER_GLB.name).read_bytes() == BLENDER_GLB.read_bytes()


def test_an_untouched_gltf_with_a_bin_file_reads_back_from_any_folder(tmp_path, capsys):
    """A .gltf whose buffer is a .bin file beside it: written byte for byte into the folder
    it was read from (by name or through a link), and self-contained into another (clean,
    convert, batch), where its bytes had referred to a .bin not there."""
    folder = tmp_path / "src"
    folder.mkdir()
    for name in (BLENDER_GLTF.name, "131_02_cut.bin"):
        shutil.copy(BLENDER_GLTF.parent / name, folder / name)
    source = folder / BLENDER_GLTF.name
    read = mc.load(source)
    out = tmp_path / "out"
    out.mkdir()
    for args, written in (
        (["clean", source, "-o", out / "c.gltf", "-q"], out / "c.gltf"),
        (["convert", source, out / "v.gltf"], out / "v.gltf"),
        (["batch", folder, "-o", out / "b", "-q", "-j", "1"], out / "b" / BLENDER_GLTF.name),
    ):
        code, _, err = run_cli(capsys, *args)
        assert code == 0, err
        back = mc.load(written)
        assert np.array_equal(back.rotations, read.rotations)
        assert np.array_equal(back.translations, read.translations)
        assert back.frame_time == read.frame_time and back.names == read.names
        document = json.loads(written.read_text())
        assert all(b["uri"].startswith("data:") for b in document["buffers"])
    (tmp_path / "link").symlink_to(folder)
    for target in (folder / "same.gltf", tmp_path / "link" / "linked.gltf"):
        mc.save(read, target)
        assert target.read_bytes() == source.read_bytes()


def tiny_png(rgb: tuple[int, int, int]) -> bytes:
    """A 1x1 RGB PNG (PNG spec: signature, IHDR, one zlib-compressed IDAT row, IEND)."""
    import zlib

    def chunk(kind: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(kind + body)
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", 1, 1, 8, 2, 0, 0, 0)  # 1x1, 8 bits, RGB
    row = zlib.compress(bytes([0, *rgb]))  # filter byte 0, then the pixel
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", row) + chunk(b"IEND", b"")


#: The textured copy's images: URI as written in the file, and the file it names.
TEXTURES = (("skin.png", "skin.png"), ("maps/normal%20map.PNG", "maps/normal map.PNG"))
FAR_IMAGE = "https://example.com/far.png"


def textured_gltf(folder, *, glb: bool = False, edit=None):
    """Blender's .gltf + .bin export (or its GLB) in ``folder`` made a textured character:
    a material whose base colour and normal textures are PNG files beside it (one in a
    subfolder, its URI percent-encoded, its mimeType given) and one more image on the web;
    then ``edit(document, folder)`` when given."""
    folder.mkdir(parents=True, exist_ok=True)
    if glb:
        document, binary = glb_parts(BLENDER_GLB)
    else:
        shutil.copy(BLENDER_GLTF.with_suffix(".bin"), folder / "131_02_cut.bin")
        document = json.loads(BLENDER_GLTF.read_text())
    for n, (_, name) in enumerate(TEXTURES):
        (folder / name).parent.mkdir(exist_ok=True)
        (folder / name).write_bytes(tiny_png((200, 40 * n, 10)))
    document["images"] = [{"uri": TEXTURES[0][0]}, {"uri": TEXTURES[1][0], "mimeType": "image/png"}]
    document["images"].append({"uri": FAR_IMAGE})
    document["textures"] = [{"source": 0}, {"source": 1}, {"source": 2}]
    document["materials"] = [
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "normalTexture": {"index": 1}}
    ]
    if edit is not None:
        edit(document, folder)
    text = json.dumps(document).encode()
    if not glb:
        (folder / "char.gltf").write_bytes(text)
        return folder / "char.gltf"
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    body += struct.pack("<II", len(binary), 0x004E4942) + binary
    (folder / "char.glb").write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)
    return folder / "char.glb"


def written_images(path) -> list[tuple[str | None, bytes | str]]:
    """Each image of a written glTF as (media type, bytes) when its bytes are in the file (a
    data URI, or a bufferView of the GLB binary chunk), else (None, its URI)."""
    if path.suffix == ".glb":
        document, binary = glb_parts(path)
    else:
        document, binary = json.loads(path.read_text()), b""
    found: list[tuple[str | None, bytes | str]] = []
    for image in document["images"]:
        if "bufferView" in image:
            view = document["bufferViews"][image["bufferView"]]
            assert view["buffer"] == 0 and "uri" not in document["buffers"][0]
            start = view.get("byteOffset", 0)
            found.append((image["mimeType"], binary[start : start + view["byteLength"]]))
        elif image["uri"].startswith("data:"):
            head, _, payload = image["uri"].partition(",")
            assert head.endswith(";base64")
            media = head.removeprefix("data:").removesuffix(";base64")
            assert image.get("mimeType", media) == media
            found.append((media, base64.b64decode(payload)))
        else:
            found.append((None, image["uri"]))
    return found


@pytest.mark.parametrize("glb", [False, True], ids=["gltf", "glb"])
def test_a_textured_gltf_written_elsewhere_carries_its_images(tmp_path, capsys, glb):
    """Images named by a relative URI are read from beside the source and put into a glTF
    written to another folder: data URIs in a .gltf (their media type given or found from
    the suffix), bufferViews of the binary chunk in a GLB; a URI on the web stays. They had
    kept their URIs, naming files not beside the output. Into the source's own folder an
    untouched file stays byte for byte."""
    source = textured_gltf(tmp_path / "src", glb=glb)
    read = mc.load(source)
    pictures = [("image/png", (source.parent / name).read_bytes()) for _, name in TEXTURES]
    out = tmp_path / "out"
    out.mkdir()
    batch = out / "b" / source.name
    for args, written in (
        (["clean", source, "-o", out / "c.gltf", "-q"], out / "c.gltf"),
        (["clean", source, "-o", out / "c.glb", "-q"], out / "c.glb"),
        (["convert", source, out / "v.gltf"], out / "v.gltf"),
        (["convert", source, out / "v.glb"], out / "v.glb"),
        (["batch", source.parent, "-o", out / "b", "-q", "-j", "1"], batch),
    ):
        code, _, err = run_cli(capsys, *args)
        assert code == 0, err
        back = mc.load(written)
        assert back.names == read.names and back.n_frames == read.n_frames
        assert written_images(written) == [*pictures, (None, FAR_IMAGE)], args
    mc.save(read, source.parent / f"same{source.suffix}")
    assert (source.parent / f"same{source.suffix}").read_bytes() == source.read_bytes()


def _image_uri(uri: str):
    """An edit of a textured glTF's document: its first image's URI made ``uri``."""
    return lambda document, folder: document["images"][0].update(uri=uri)


def _linked_out(document: dict, folder) -> None:
    """An edit: the first image a link in the glTF's folder to a file outside it."""
    (folder / "link.png").symlink_to(folder.parent / "up.png")
    document["images"][0]["uri"] = "link.png"


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (_image_uri("../up.png"), "images[0]: uri '../up.png' climbs out of the glTF's folder"),
        (_linked_out, "images[0]: uri 'link.png' links outside the glTF's folder"),
        (_image_uri(""), "images[0]: uri '' names no file"),
        (_image_uri("skin%00.png"), "images[0]: uri 'skin%00.png' holds a NUL byte"),
        (lambda document, folder: document.update(images=5), "'images' is not a list of"),
        (lambda document, folder: document.update(images="skin.png"), "'images' is not a list"),
    ],
    ids=["climbs", "link", "empty", "nul", "number", "string"],
)
def test_an_image_that_cannot_be_carried_is_one_line(tmp_path, capsys, suffix, edit, message):
    """An image to carry into another folder whose URI names a file outside the source's
    folder (by ``..`` or through a link: its bytes would be put into the output), names no
    file or holds a NUL byte, or images that are not a list, are one error line naming the
    source and the image, exit code 1, and nothing is written (a .gltf + .bin to a .gltf,
    a GLB to a GLB). The link had carried the file it leads to; the NUL and, from a GLB,
    the number had been internal errors, the string ignored."""
    (tmp_path / "up.png").write_bytes(tiny_png((1, 2, 3)))
    source = textured_gltf(tmp_path / "src", glb=suffix == ".glb", edit=edit)
    (tmp_path / "out").mkdir()
    target = tmp_path / "out" / f"char{suffix}"
    code, out, err = run_cli(capsys, "convert", source, target)
    expected = f"motionclean: error: {source}: {message}"
    assert code == 1 and err.count("\n") == 1 and err.startswith(expected), err
    assert not target.exists()
    said = kinematics.source_notes(mc.load(source))  # read, and said before any cleaning
    assert [n for n in said if n.startswith(message) and n.endswith(REFUSED)], said


#: The end of the note of a glTF whose images cannot be carried into another folder.
REFUSED = "writing it as glTF to another folder is refused"


def test_an_image_not_beside_the_source_keeps_its_uri_and_a_note_says_so(tmp_path, capsys):
    """Images that are not there (textures nobody copied), a folder, or of no known type
    keep their URIs in a glTF written to another folder, each named in a note when the
    clip is read; the clip is written (they had failed it, after the cleaning). An image
    with a query is carried (the query is no part of its name: it had been "no such
    file"), as is a link to an image inside the folder; ``"images": null`` names none."""
    source = textured_gltf(tmp_path / "src")
    folder = source.parent
    (folder / "skin.tga").write_bytes(b"TGA")
    (folder / "alias.png").symlink_to("maps/normal map.PNG")
    document = json.loads(source.read_text())
    kept = ["gone.png", "skin.tga", "maps"]
    carried = ["skin.png?v=2#top", "alias.png"]
    document["images"] = [{"uri": uri} for uri in kept + carried]
    source.write_text(json.dumps(document))
    pictures = [("image/png", (folder / name).read_bytes()) for _, name in TEXTURES]
    notes = [
        f"images[0] 'gone.png': no such file beside the glTF; {KEPT}",
        f"images[1] 'skin.tga': no mimeType, and no image type by its suffix; {KEPT}",
        f"images[2] 'maps': not a file (a folder, pipe or device); {KEPT}",
    ]
    assert kinematics.source_notes(mc.load(source)) == tuple(notes)
    out = tmp_path / "out"
    out.mkdir()
    for args, written in (
        (["convert", source, out / "v.gltf"], out / "v.gltf"),
        (["convert", source, out / "v.glb"], out / "v.glb"),
        (["clean", source, "-o", out / "c.gltf", "-q"], out / "c.gltf"),
        (["batch", folder, "-o", out / "b", "-q", "-j", "1"], out / "b" / source.name),
    ):
        code, said, err = run_cli(capsys, *args)
        assert code == 0 and err == "", err
        assert written_images(written) == [(None, uri) for uri in kept] + pictures, args
        assert args[0] != "convert" or said.splitlines() == [f"note: {n}" for n in notes]
    (folder / "none.gltf").write_text(json.dumps(document | {"images": None}))
    code, said, err = run_cli(capsys, "convert", folder / "none.gltf", out / "none.gltf")
    assert code == 0 and err == "" and json.loads((out / "none.gltf").read_text())["images"] is None


#: The end of the note of an image a glTF written to another folder does not carry.
KEPT = "a glTF written to another folder keeps this uri, not the image"


def test_a_buffer_linked_in_from_outside_the_folder_is_refused(tmp_path, capsys):
    """A ``.bin`` that is a link to a file outside the glTF's folder is refused in one line
    (its bytes would be embedded in a glTF written elsewhere: ``x.bin -> /etc/passwd``);
    a link to a file inside the folder reads."""
    folder = tmp_path / "src"
    (folder / "data").mkdir(parents=True)
    source = folder / BLENDER_GLTF.name
    shutil.copy(BLENDER_GLTF, source)
    (folder / "131_02_cut.bin").symlink_to(BLENDER_GLTF.with_suffix(".bin"))
    code, out, err = run_cli(capsys, "info", source)
    message = "buffers[0]: uri '131_02_cut.bin' links outside the glTF's folder"
    assert code == 1 and err == f"motionclean: error: {source}: {message}\n", err
    (folder / "131_02_cut.bin").unlink()
    shutil.copy(BLENDER_GLTF.with_suffix(".bin"), folder / "data" / "cut.bin")
    (folder / "131_02_cut.bin").symlink_to("data/cut.bin")
    assert mc.load(source).n_frames == mc.load(BLENDER_GLTF).n_frames == 24


def test_an_armature_node_s_turn_gives_the_up_axis_and_its_scale_a_note(tmp_path):
    """glTF's scene is +Y up (3.4): the up of the skeleton's own coordinates is what the
    nodes above it turn +Y onto. Blender's export has none turning it: up y. Under an
    armature turned a quarter turn about x and scaled by 100 (as FBX2glTF writes), the
    skeleton's up is -z, said with a note, and the clip reads the same otherwise."""
    import json
    import shutil

    plain = mc.load(BLENDER_GLTF)
    assert plain.up == "y" and not kinematics.source_notes(plain)
    document = json.loads(BLENDER_GLTF.read_text())
    top = document["scenes"][0]["nodes"][0]
    half = np.sqrt(0.5)
    document["nodes"].append(
        {"name": "Armature", "rotation": [half, 0.0, 0.0, half], "scale": [100.0] * 3,
         "children": [top]}
    )  # fmt: skip
    document["scenes"][0]["nodes"] = [len(document["nodes"]) - 1]
    shutil.copy(BLENDER_GLTF.with_suffix(".bin"), tmp_path / BLENDER_GLTF.with_suffix(".bin").name)
    turned = tmp_path / "turned.gltf"
    turned.write_text(json.dumps(document))
    clip = mc.load(turned)
    assert clip.up == "-z" and kinematics.up_name(clip) == "-z"
    assert any("hangs under node 'Armature' (scale 100" in n for n in kinematics.source_notes(clip))
    assert np.array_equal(clip.rotations, plain.rotations)


def test_a_vrm_animation_is_read_and_written_as_the_glb_it_is(tmp_path, capsys):
    """A ``.vrma`` (VRM animation) is a GLB whose VRMC_vrm_animation extension maps its
    nodes to humanoid bones (three-vrm's example): read as a GLB, an untouched one written
    back byte for byte, a changed one keeps its extension (and the rest of its JSON)."""
    clip = mc.load(VRMA)
    assert clip.names[0] == "hips" and clip.n_frames == 7  # the humanoid: tests/io/test_vrma.py
    mc.save(clip, tmp_path / "same.vrma")
    assert (tmp_path / "same.vrma").read_bytes() == VRMA.read_bytes()
    q = clip.rotations.copy()
    q[3, 0] = quat.multiply(q[3, 0], quat.from_axis_angle(np.array([0.0, 0.0, 1.0]), 0.1))
    mc.save(clip.replace(rotations=q), tmp_path / "moved.vrma")
    document, _ = glb_parts(tmp_path / "moved.vrma")
    original, _ = glb_parts(VRMA)
    assert document["extensions"] == original["extensions"]
    assert document["extensionsUsed"] == ["VRMC_vrm_animation"]
    assert degrees(mc.load(tmp_path / "moved.vrma").rotations, q) < 1e-4
    code, _, err = run_cli(capsys, "convert", VRMA, tmp_path / "back.glb")
    assert code == 0, err


def test_vrma_output_needs_a_vrm_animation(tmp_path, capsys):
    """A GLB of another clip written as .vrma had been a byte copy of the GLB under the
    name (no humanoid bone map: no VRM tool loads it), silently. Refused in one line, as
    any output the clip cannot make; a GLB renamed .vrma still reads."""
    for source in (BLENDER_GLB, SAMPLE):
        target = tmp_path / f"{source.stem}.vrma"
        code, out, err = run_cli(capsys, "convert", source, target)
        assert code == 1 and out == "" and not target.exists()
        assert err == (
            f"motionclean: error: {source}: a .vrma is a VRM animation (VRMC_vrm_animation: "
            "nodes mapped to humanoid bones); this clip is not read from one: write .glb\n"
        )
    renamed = tmp_path / "renamed.vrma"
    renamed.write_bytes(BLENDER_GLB.read_bytes())
    assert np.array_equal(mc.load(renamed).rotations, mc.load(BLENDER_GLB).rotations)
    code, _, err = run_cli(capsys, "clean", renamed, "-o", tmp_path / "clean.vrma", "-q")
    assert code == 1 and "this clip is not read from one" in err


def _offset_numbers(path) -> list[str]:
    lines = [line.split() for line in path.read_text().splitlines()]
    return [number for words in lines if words[:1] == ["OFFSET"] for number in words[1:]]


def test_a_bvh_of_a_glb_writes_offsets_in_one_fixed_point_format(tmp_path, capsys):
    """Offsets from a glTF (float32 values) had been written as six decimals where that
    was exact and repr elsewhere: 3.2861585168575402e-06 beside 2.183881998062134. One
    fixed-point format, float32's precision of the skeleton's size, no exponent; a
    skeleton given in doubles keeps up to twelve significant digits, without their noise."""
    code, _, err = run_cli(capsys, "convert", BLENDER_GLB, tmp_path / "b.bvh")
    assert code == 0, err
    numbers = _offset_numbers(tmp_path / "b.bvh")
    assert {len(n.split(".")[1]) for n in numbers} == {6} and not any("e" in n for n in numbers)
    assert numbers[3:6] == ["0.000003", "0.000002", "0.000001"]
    read, back = mc.load(BLENDER_GLB), mc.load(tmp_path / "b.bvh")
    assert np.abs(back.offsets - read.offsets).max() <= 5e-7
    bvh = mc.load(SAMPLE)  # an edited skeleton of doubles: a new hierarchy
    offsets = bvh.offsets.copy()
    offsets[1] = [0.1 + 0.2, -1.5785620936767598e-27, -0.0846 - 1e-17]  # (no -0.000000)
    mc.save(bvh.replace(offsets=offsets), tmp_path / "m.bvh")
    numbers = _offset_numbers(tmp_path / "m.bvh")
    assert numbers[3:6] == ["0.300000", "0.000000", "-0.084600"]
    assert {len(n.split(".")[1]) for n in numbers} == {6}
    offsets[2] = [1.23456789, 0.0, 0.0]
    mc.save(bvh.replace(offsets=offsets), tmp_path / "m.bvh")
    numbers = _offset_numbers(tmp_path / "m.bvh")
    assert numbers[6] == "1.23456789" and {len(n.split(".")[1]) for n in numbers} == {8}
    assert np.array_equal(mc.load(tmp_path / "m.bvh").offsets[2], offsets[2])


def test_the_frame_time_of_float32_keys_is_made_exact(tmp_path, capsys):
    """A BVH of Frame Time .0083333 through a GLB had come back saying 0.00833330026837097
    (the float32 keys' step; 300 frames drift too far off 1/120's grid to snap): the step
    is the shortest decimal within the keys' float32 rounding, and an NTSC rate's exact."""
    code, _, err = run_cli(capsys, "convert", SAMPLE, tmp_path / "s.glb")
    assert code == 0, err
    code, _, err = run_cli(capsys, "convert", tmp_path / "s.glb", tmp_path / "back.bvh")
    assert code == 0, err
    assert "Frame Time: 0.0083333\n" in (tmp_path / "back.bvh").read_text()
    clip = mc.load(SAMPLE)
    for written, read in (
        (1001 / 30000, 1001 / 30000),  # NTSC's 29.97 fps, exactly
        (1 / 29.97, 0.0333667),
        (1 / 37.5, 0.02666667),
        (0.013, 0.013),
        (1 / 60, 1 / 60),
    ):
        mc.save(clip.replace(frame_time=written), tmp_path / "r.glb")
        assert mc.load(tmp_path / "r.glb").frame_time == read


def test_cleaning_the_glb_equals_cleaning_the_bvh(bvh_96, tmp_path, capsys):
    code, _, err = run_cli(capsys, "clean", BLENDER_GLB, "-o", tmp_path / "c.glb", "-q")
    assert code == 0, err
    code, _, err = run_cli(capsys, "clean", bvh_96, "-o", tmp_path / "c.bvh", "-q")
    assert code == 0, err
    glb, bvh = mc.load(tmp_path / "c.glb"), mc.load(tmp_path / "c.bvh")
    p_glb, r_glb = relative_world(glb, bvh.names)
    p_bvh, r_bvh = relative_world(bvh, bvh.names)
    assert np.abs(p_glb - p_bvh).max() < 1e-3  # float32 against six decimals
    assert degrees(r_glb, r_bvh) < 0.01
    thumb = bvh.names.index("RThumb")
    _, before = relative_world(mc.load(bvh_96), bvh.names)
    assert degrees(before[:, thumb], r_bvh[:, thumb]) > 90  # the half-turn flips repaired


def test_written_file_keeps_every_other_part(tmp_path):
    motion = mc.load(BLENDER_GLB)
    hips = motion.names.index("Hips")
    q = motion.rotations.copy()
    q[10:20, hips] = quat.multiply(q[10:20, hips], quat.exp(np.array([0.0, 0.01, 0.0])))
    t = motion.translations.copy()
    t[5, hips] += [0.5, 0.0, 0.0]
    edited = motion.replace(rotations=q, translations=t)
    mc.save(edited, tmp_path / "e.glb")
    before, bin_before = glb_parts(BLENDER_GLB)
    after, bin_after = glb_parts(tmp_path / "e.glb")
    assert bin_after[: len(bin_before)] == bin_before  # appended, never rewritten
    for key in set(before) - {"accessors", "bufferViews", "buffers", "animations"}:
        assert after[key] == before[key]
    for key in ("accessors", "bufferViews"):
        assert after[key][: len(before[key])] == before[key]
    assert len(after["accessors"]) == len(before["accessors"]) + 2  # hips rotation, translation
    old, new = before["animations"][0], after["animations"][0]
    moved = [
        c for c, (a, b) in enumerate(zip(old["channels"], new["channels"], strict=True)) if a != b
    ]
    node = motion.source.nodes[hips]
    assert {new["channels"][c]["target"]["node"] for c in moved} == {node}
    assert new["samplers"][: len(old["samplers"])] == old["samplers"]
    back = mc.load(tmp_path / "e.glb")
    assert np.abs(np.abs(np.einsum("fji,fji->fj", back.rotations, q)) - 1).max() < 1e-12
    assert np.abs(back.translations - t).max() < 1e-5
    others = np.ones(motion.n_joints, dtype=bool)
    others[hips] = False
    assert np.array_equal(back.rotations[:, others], motion.rotations[:, others])


def test_a_changed_gltf_is_self_contained(tmp_path):
    motion = mc.load(BLENDER_GLTF)
    q = motion.rotations.copy()
    q[3, 5] = quat.multiply(q[3, 5], quat.exp(np.array([0.02, 0.0, 0.0])))
    (tmp_path / "elsewhere").mkdir()
    mc.save(motion.replace(rotations=q), tmp_path / "elsewhere" / "e.gltf")
    document = json.loads((tmp_path / "elsewhere" / "e.gltf").read_text())
    assert all(b["uri"].startswith("data:") for b in document["buffers"])
    back = mc.load(tmp_path / "elsewhere" / "e.gltf")
    assert np.abs(np.abs(np.einsum("fji,fji->fj", back.rotations, q)) - 1).max() < 1e-12
    mc.save(motion.replace(rotations=q), tmp_path / "e.glb")  # and as a GLB
    assert np.array_equal(mc.load(tmp_path / "e.glb").rotations, back.rotations)


# ----------------------------------------------------------------------------- made files


class Builder:
    """A small glTF made in the test: nodes, one animation, one buffer."""

    def __init__(self):
        self.doc: dict = {
            "asset": {"version": "2.0"},
            "nodes": [],
            "accessors": [],
            "bufferViews": [],
            "animations": [{"channels": [], "samplers": []}],
        }
        self.data = b""

    def accessor(self, values, kind: str) -> int:
        raw = np.asarray(values, dtype="<f4").tobytes()
        self.doc["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw)}
        )
        self.data += raw
        self.doc["accessors"].append(
            {
                "bufferView": len(self.doc["bufferViews"]) - 1,
                "componentType": 5126,
                "count": len(values),
                "type": kind,
            }
        )
        return len(self.doc["accessors"]) - 1

    def channel(self, node: int, path: str, times, values, interpolation="LINEAR") -> None:
        animation = self.doc["animations"][0]
        kind = {"rotation": "VEC4", "translation": "VEC3", "scale": "VEC3"}[path]
        animation["samplers"].append(
            {
                "input": self.accessor(np.asarray(times)[:, None], "SCALAR"),
                "output": self.accessor(values, kind),
                "interpolation": interpolation,
            }
        )
        animation["channels"].append(
            {"sampler": len(animation["samplers"]) - 1, "target": {"node": node, "path": path}}
        )

    def gltf(self, path) -> None:
        self.doc["buffers"] = [
            {
                "byteLength": len(self.data),
                "uri": "data:application/octet-stream;base64,"
                + base64.b64encode(self.data).decode(),
            }
        ]
        path.write_text(json.dumps(self.doc))


def z_turn(angle: np.ndarray) -> np.ndarray:
    """glTF (x, y, z, w) quaternions of turns about Z."""
    return np.stack([0 * angle, 0 * angle, np.sin(angle / 2), np.cos(angle / 2)], axis=-1)


def chain() -> Builder:
    made = Builder()
    made.doc["nodes"] = [
        {"name": "root", "children": [1], "translation": [0, 1, 0]},
        {"name": "mid", "children": [2], "translation": [0, 1, 0], "rotation": [0, 0, 0.6, 0.8]},
        {"name": "tip", "translation": [0, 1, 0]},
    ]
    made.doc["scenes"] = [{"nodes": [0]}]
    made.doc["skins"] = [{"joints": [2, 0, 1]}]
    return made


@pytest.mark.parametrize(
    ("scaled", "unit"),
    [
        (None, "m"),
        ("keyed 1", "m"),  # (Blender keys a scale of 1 on every bone)
        ("keyed 1.00006", "m"),  # (a three.js sample's bones, exported by Blender)
        ("joint", None),
        ("keyed 2", None),
        ("above", None),  # (an armature node over the skeleton)
    ],
)
def test_lengths_are_metres_where_no_node_of_the_armature_is_scaled(tmp_path, capsys, scaled, unit):
    """glTF's lengths are metres (3.4), and the reports say `m`, where no node of the
    armature (its joints and the nodes above them) has a scale other than 1, set or keyed:
    scale is not read, so under one the lengths are the skeleton's own units. A scale
    within 1e-3 of 1 is one (a Blender export's bones keyed at 0.99994-1.00006 had read as
    scaled: "units")."""
    made = chain()
    grid = np.arange(4) / 30.0
    made.channel(0, "translation", grid, [[0, 1 + 0.1 * k, 0] for k in range(4)])
    if scaled == "joint":
        made.doc["nodes"][1]["scale"] = [2.0, 2.0, 2.0]
    elif scaled is not None and scaled.startswith("keyed"):
        factor = float(scaled.split()[1])
        made.channel(1, "scale", grid, [[1.0, 1.0, 1.0]] * 3 + [[factor] * 3])
    elif scaled == "above":
        made.doc["nodes"].append({"name": "Armature", "scale": [0.01] * 3, "children": [0]})
        made.doc["scenes"] = [{"nodes": [3]}]
    made.gltf(tmp_path / "c.gltf")
    clip = mc.load(tmp_path / "c.gltf")
    assert kinematics.length_unit(clip) == unit
    code, _, err = run_cli(capsys, "report", tmp_path / "c.gltf", "--json", tmp_path / "r.json")
    assert code == 0, err
    assert json.loads((tmp_path / "r.json").read_text()).get("length_unit") == unit


def test_a_gltf_written_from_another_format_says_no_unit(tmp_path, capsys):
    """motionclean writes a BVH's lengths into a new glTF as they are (a CMU body 24 units
    tall, not metres): reading it back, it says `units`, not `m`."""
    code, _, err = run_cli(capsys, "convert", SAMPLE, tmp_path / "c.glb")
    assert code == 0, err
    assert kinematics.length_unit(mc.load(tmp_path / "c.glb")) is None
    assert kinematics.length_unit(mc.load(BLENDER_GLB)) == "m"  # (Blender's export)
    code, out, _ = run_cli(capsys, "info", tmp_path / "c.glb")
    assert code == 0 and "body height: 24.27 units" in out


def test_samplers_are_evaluated_as_the_specification_says(tmp_path):
    made = chain()
    grid = np.arange(0, 31) / 30.0
    made.channel(0, "translation", grid, np.stack([grid, 0 * grid, 0 * grid], axis=-1))
    sparse = np.array([0.0, 0.5, 1.0])  # keys every 15 frames: slerp between them
    made.channel(0, "rotation", sparse, z_turn(np.array([0.0, 1.0, 3.0])))
    made.channel(2, "rotation", sparse, z_turn(np.array([0.0, 0.4, 0.8])), "STEP")
    # a Hermite spline in the angle about Z: (in-tangent, value, out-tangent) per key
    keys, values, slopes = np.array([0.0, 1.0]), np.array([0.0, 2.0]), np.array([1.0, -1.0])
    spline = np.stack([z_turn(slopes) * 0, z_turn(values), z_turn(values) * 0], axis=1)
    spline[:, 0, 2] = spline[:, 2, 2] = slopes / 2 * np.cos(values / 2)  # d(sin(a/2))/dt
    spline[:, 0, 3] = spline[:, 2, 3] = -slopes / 2 * np.sin(values / 2)  # d(cos(a/2))/dt
    made.channel(1, "rotation", keys, spline.reshape(-1, 4), "CUBICSPLINE")
    made.gltf(tmp_path / "made.gltf")
    motion = mc.load(tmp_path / "made.gltf")
    assert motion.names == ["root", "mid", "tip"] and motion.n_frames == 31
    assert motion.frame_rate == 30.0 and motion.parents.tolist() == [-1, 0, 1]
    root = 2 * np.arctan2(motion.rotations[:, 0, 3], motion.rotations[:, 0, 0])
    expected = np.interp(grid, sparse, [0.0, 1.0, 3.0])  # slerp about one axis: linear angle
    assert np.abs(root - expected).max() < 1e-6
    tip = 2 * np.arctan2(motion.rotations[:, 2, 3], motion.rotations[:, 2, 0])
    assert (
        np.abs(tip - np.where(grid < 0.5 - 1e-9, 0.0, np.where(grid < 1 - 1e-9, 0.4, 0.8))).max()
        < 1e-6
    )
    u = grid
    h = [2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2]
    h = [c[:, None] for c in h]
    q = h[0] * spline[0, 1] + h[1] * spline[0, 2] + h[2] * spline[1, 1] + h[3] * spline[1, 0]
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    assert (
        np.abs(np.abs(np.einsum("fi,fi->f", motion.rotations[:, 1], q[:, [3, 0, 1, 2]])) - 1).max()
        < 1e-12
    )
    assert np.array_equal(motion.translations[:, 0, 0], grid.astype(np.float32).astype(float))
    mc.save(motion, tmp_path / "same.gltf")
    assert (tmp_path / "same.gltf").read_bytes() == (tmp_path / "made.gltf").read_bytes()
    smoothed = motion.replace(
        rotations=mc.filters.lee_shin(motion.rotations, mc.filters.masks.binomial(2))
    )
    mc.save(smoothed, tmp_path / "smooth.gltf")
    document = json.loads((tmp_path / "smooth.gltf").read_text())
    samplers = document["animations"][0]["samplers"]
    assert [s["interpolation"] for s in samplers[:4]] == ["LINEAR", "LINEAR", "STEP", "CUBICSPLINE"]
    back = mc.load(tmp_path / "smooth.gltf")
    assert (
        np.abs(np.abs(np.einsum("fji,fji->fj", back.rotations, smoothed.rotations)) - 1).max()
        < 1e-12
    )


def test_convert_to_bvh_and_from_other_formats(tmp_path, capsys):
    code, _, _ = run_cli(capsys, "convert", BLENDER_GLB, tmp_path / "g.bvh")
    assert code == 0
    names = mc.load(tmp_path / "g.bvh").names
    p_glb, r_glb = relative_world(mc.load(BLENDER_GLB), names)
    p_bvh, r_bvh = relative_world(mc.load(tmp_path / "g.bvh"), names)
    assert np.abs(p_glb - p_bvh).max() < 1e-4 and degrees(r_glb, r_bvh) < 0.01
    for suffix in (".glb", ".gltf"):  # a BVH as a new glTF: nodes, skin, one animation
        code, _, _ = run_cli(capsys, "convert", SAMPLE, tmp_path / f"s{suffix}")
        assert code == 0
        bvh, glb = mc.load(SAMPLE), mc.load(tmp_path / f"s{suffix}")
        assert glb.names == bvh.names and sorted(glb.end_sites) == sorted(bvh.end_sites)
        p_bvh, _ = kinematics.forward(bvh, end_sites=True)
        p_glb, _ = kinematics.forward(glb, end_sites=True)
        assert np.abs(p_glb - p_bvh).max() < 1e-4
        assert abs(glb.frame_time - bvh.frame_time) < 1e-9
    np.savez(tmp_path / "s.npz", poses=np.zeros((3, 72)))
    code, _, err = run_cli(capsys, "convert", tmp_path / "s.npz", tmp_path / "s2.glb")
    assert code == 1 and "glTF needs joint positions: SMPL parameters hold no joint" in err
    assert not (tmp_path / "s2.glb").exists()


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d[:30], "the header says 67672 bytes, the file has 30"),
        (lambda d: d[:8] + struct.pack("<I", 30) + d[12:30], "chunk runs past the end"),
        (lambda d: b"glTX" + d[4:], "not a GLB file"),
        (lambda d: d[:8] + struct.pack("<I", len(d) + 4) + d[12:], "the header says"),
        (lambda d: d[:20] + b"[" + d[21:], "the glTF JSON does not parse"),
    ],
)
def test_bad_glb_is_one_line(tmp_path, capsys, mutate, message):
    (tmp_path / "bad.glb").write_bytes(mutate(BLENDER_GLB.read_bytes()))
    code, out, err = run_cli(capsys, "info", tmp_path / "bad.glb")
    assert code == 1 and out == "" and err.count("\n") == 1 and message in err


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["accessors"][0].update(count=10**9), "do not fit in their bufferView"),
        (lambda d: d["accessors"][0].update(sparse={}), "sparse accessors are not read"),
        (lambda d: d["nodes"][2].update(children=[0]), "the node tree has a cycle"),
        (lambda d: d["nodes"][0].update(children=[1, 1]), "node 1 has two parents"),
        (lambda d: d["animations"][0]["samplers"][0].update(interpolation="BEZIER"), "is unknown"),
        (
            lambda d: d["animations"][0]["samplers"][0].update(interpolation="CUBICSPLINE"),
            "11 outputs for 11 keys (CUBICSPLINE: expected 33)",
        ),
        (lambda d: d["asset"].update(version="1.0"), "only glTF 2.0 is read"),
        (lambda d: d["buffers"][0].update(uri="../../etc/passwd"), "climbs out of the glTF's"),
        (
            lambda d: d["buffers"][0].update(uri="x%00.bin"),
            "buffers[0]: uri 'x%00.bin' holds a NUL",
        ),
        (lambda d: d["buffers"][0].update(uri=""), "buffers[0]: uri '' names no file"),
        (lambda d: d["buffers"][0].update(uri="."), "buffers[0]: is a directory, not a buffer"),
        (lambda d: d["buffers"][0].update(uri="/etc/passwd"), "is a URL or an absolute path"),
        (  # had been an internal error (urlsplit's ValueError)
            lambda d: d["buffers"][0].update(uri="//[x.bin"),
            "buffers[0]: uri '//[x.bin' is not a valid URI",
        ),
        (lambda d: d["skins"][0].update(joints=[7]), "is not an index below 3"),
        (  # had read "24 is not a count", as if a count
            lambda d: d["accessors"][0].update(count="24"),
            'accessors[0].count: the string "24" is not a count',
        ),
        (  # would overflow the body height (a fuzzed file printed "body height inf")
            lambda d: d["nodes"][1].update(translation=[0.0, -1e308, 0.0]),
            "nodes[1]: translation or rotation is not 3 or 4 numbers of at most 1e+12 in size",
        ),
        (  # would overflow the quaternion's norm (numpy's warning had leaked to stderr)
            lambda d: d["nodes"][1].update(rotation=[1e300, 0.0, 0.0, 1e300]),
            "is not 3 or 4 numbers of at most 1e+12 in size",
        ),
    ],
)
def test_bad_gltf_is_one_line(tmp_path, capsys, edit, message):
    made = chain()
    grid = np.arange(0, 11) / 10.0
    made.channel(0, "rotation", grid, z_turn(grid))
    made.gltf(tmp_path / "ok.gltf")
    document = json.loads((tmp_path / "ok.gltf").read_text())
    edit(document)
    (tmp_path / "bad.gltf").write_text(json.dumps(document))
    code, out, err = run_cli(capsys, "info", tmp_path / "bad.gltf")
    assert code == 1 and out == "" and err.count("\n") == 1 and message in err, err


def test_a_blender_glb_has_the_body_height_and_feet_of_its_bvh():
    """Blender's glTF stacks every bone along its own y in the bind pose (identity
    rotations): not a standing rest, so the height comes from the poses, within 5 % of the
    BVH's T-pose height, and the feet are the same ankles (a height from the stacked rest,
    18.65 of 24.27, made the toe bone 'long' and LeftToe a foot)."""
    glb, bvh = mc.load(BLENDER_GLB), mc.load(SAMPLE)
    assert kinematics.body_height(glb) == pytest.approx(kinematics.body_height(bvh), rel=0.05)
    feet = [foot.name for foot in contacts.skeleton_feet(glb)[0]]
    assert sorted(feet) == sorted(foot.name for foot in contacts.skeleton_feet(bvh)[0])


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_a_glb_resampled_or_stitched_is_written_at_its_new_frames(tmp_path, capsys, suffix):
    """New frames are written as new keys into the file's own document (an assertion that
    the read rotations were still there had made both an internal error)."""
    source = mc.load(BLENDER_GLB)
    resampled, _ = mc.Pipeline.from_inline(["resample:fps=60"]).run(source)
    code, _, err = run_cli(capsys, "resample", BLENDER_GLB, tmp_path / f"r{suffix}", "--fps", "60")
    assert code == 0, err
    back = mc.load(tmp_path / f"r{suffix}")
    assert back.n_frames == resampled.n_frames and back.frame_time == pytest.approx(1 / 60)
    assert degrees(back.rotations, resampled.rotations) < 1e-4
    p_back, p_expected = kinematics.forward(back)[0], kinematics.forward(resampled)[0]
    assert np.abs(p_back - p_expected).max() < 1e-5 * kinematics.body_height(source)
    stitched = tmp_path / f"s{suffix}"
    code, _, err = run_cli(capsys, "stitch", BLENDER_GLB, BLENDER_GLB, "-o", stitched)
    assert code == 0, err
    assert mc.load(stitched).n_frames > source.n_frames


def test_the_animation_named_is_read_cleaned_and_written_alone(tmp_path, capsys):
    """A file of several animations (a character's Idle, Walk, Run): ``--animation`` reads
    the one named, and cleaning it leaves every other animation as it was."""
    document = json.loads(BLENDER_GLTF.read_text())
    (tmp_path / "131_02_cut.bin").write_bytes((BLENDER_GLTF.parent / "131_02_cut.bin").read_bytes())
    idle = dict(document["animations"][0], name="Idle")
    channels = idle["channels"]
    walk = dict(idle, name="Walk", channels=channels[: len(channels) // 2])  # half the joints
    document["animations"] = [idle, walk]
    source = tmp_path / "two.gltf"
    source.write_text(json.dumps(document))
    first, named = mc.load(source), mc.load(source, animation="Walk")
    assert not np.allclose(named.rotations, first.rotations)
    assert np.array_equal(named.rotations, mc.load(source, animation=1).rotations)
    target = tmp_path / "clean.gltf"
    args = ["clean", source, "-o", target, "-q", "-f", "lee-shin:k=3", "--animation", "Walk"]
    code, _, err = run_cli(capsys, *args)
    assert code == 0, err
    after = json.loads(target.read_text())
    assert after["animations"][0] == document["animations"][0]  # Idle untouched
    assert after["animations"][1]["channels"] != walk["channels"]
    idle, cleaned = mc.load(target), mc.load(target, animation="1")
    assert np.array_equal(idle.rotations, mc.load(source).rotations)
    assert not np.allclose(cleaned.rotations, idle.rotations)
    code, _, err = run_cli(capsys, "info", source, "--animation", "Jog")
    assert code == 1
    assert err.strip().endswith("no animation 'Jog': the file has 2 animations: 'Idle', 'Walk'")
    del walk["name"]  # an unnamed one is asked for by its index, and said so
    source.write_text(json.dumps(document))
    code, _, err = run_cli(capsys, "info", source, "--animation", "Jog")
    assert code == 1 and err.strip().endswith(
        "the file has 2 animations: 'Idle', number 1 (unnamed)"
    )
    assert run_cli(capsys, "info", source, "--animation", "1")[0] == 0


def split_per_joint(document: dict) -> dict:
    """``document`` with its animation split as COLLADA2GLTF writes one: an unnamed
    animation per node, holding that node's channels and their samplers."""
    whole = document["animations"][0]
    by_node: dict[int, dict] = {}
    for channel in whole["channels"]:
        part = by_node.setdefault(channel["target"]["node"], {"channels": [], "samplers": []})
        part["samplers"].append(whole["samplers"][channel["sampler"]])
        part["channels"].append({"sampler": len(part["samplers"]) - 1, "target": channel["target"]})
    return dict(document, animations=list(by_node.values()))


def moving_nodes(motion: mc.Motion) -> set[int]:
    """The nodes of the joints whose rotation changes over the clip."""
    still = np.all(motion.rotations == motion.rotations[:1], axis=(0, 2))
    return {node for node, held in zip(motion.source.nodes, still, strict=True) if not held}


def test_an_animation_per_joint_is_read_and_written_as_one_motion(tmp_path, capsys):
    """COLLADA2GLTF writes each joint's channels as an animation of its own, on one time
    base, and viewers play them together: they had been read as the first one alone (only
    the root moving, the other joints never cleaned). Read as one motion, the split file is
    the whole one's, cleans to its rotations, and each channel is written back into the
    animation it came from, the others untouched."""
    (tmp_path / "131_02_cut.bin").write_bytes((BLENDER_GLTF.parent / "131_02_cut.bin").read_bytes())
    document = json.loads(BLENDER_GLTF.read_text())
    split = split_per_joint(document)
    assert len(split["animations"]) == 31
    whole_path, split_path = tmp_path / "whole.gltf", tmp_path / "split.gltf"
    whole_path.write_text(json.dumps(document))
    split_path.write_text(json.dumps(split))
    whole, read = mc.load(whole_path), mc.load(split_path)
    assert np.array_equal(read.rotations, whole.rotations)
    assert np.array_equal(read.translations, whole.translations)
    assert len(moving_nodes(read)) > 20
    code, out, err = run_cli(capsys, "info", split_path)
    assert code == 0, err
    assert "31 animations, each keying other joints over the same key times, are read as one" in out
    alone = mc.load(split_path, animation="0")  # one asked for: that one alone, as before
    assert moving_nodes(alone) <= {c["target"]["node"] for c in split["animations"][0]["channels"]}
    outputs = {}
    for name, source in (("whole", whole_path), ("split", split_path)):
        outputs[name] = tmp_path / f"{name}_clean.gltf"
        args = ["clean", source, "-o", outputs[name], "-q", "-f", "lee-shin:k=3"]
        code, _, err = run_cli(capsys, *args)
        assert code == 0, err
    cleaned, expected = mc.load(outputs["split"]), mc.load(outputs["whole"])
    assert np.abs(cleaned.rotations - expected.rotations).max() < 1e-7  # float32 written
    moved = np.any(cleaned.rotations != read.rotations, axis=(0, 2))
    changed = {node for node, m in zip(read.source.nodes, moved, strict=True) if m}
    assert len(changed) > 10
    after = json.loads(outputs["split"].read_text())["animations"]
    for before, now in zip(split["animations"], after, strict=True):
        node = before["channels"][0]["target"]["node"]
        assert (now == before) == (node not in changed)
        assert now["samplers"][: len(before["samplers"])] == before["samplers"]
        assert all(c["sampler"] < len(now["samplers"]) for c in now["channels"])


def test_animations_per_joint_on_other_times_are_read_one_at_a_time(tmp_path, capsys):
    """Animations keying other joints on different key times are not merged: the first is
    read, as before, and the note says that the others animate other joints."""
    (tmp_path / "131_02_cut.bin").write_bytes((BLENDER_GLTF.parent / "131_02_cut.bin").read_bytes())
    split = split_per_joint(json.loads(BLENDER_GLTF.read_text()))
    accessors = split["accessors"]
    for sampler in split["animations"][5]["samplers"]:  # one animation a key shorter
        for key in ("input", "output"):
            accessors.append(
                dict(accessors[sampler[key]], count=accessors[sampler[key]]["count"] - 1)
            )
            sampler[key] = len(accessors) - 1
    source = tmp_path / "split.gltf"
    source.write_text(json.dumps(split))
    first = {c["target"]["node"] for c in split["animations"][0]["channels"]}
    assert moving_nodes(mc.load(source)) <= first
    code, out, err = run_cli(capsys, "info", source)
    assert code == 0, err
    assert (
        "31 animations each key other joints, on different key times: the first ('0') is read"
        in out
    )
    assert "--animation NAME reads another" in out


def test_convert_takes_the_up_axis_it_is_told(tmp_path, capsys):
    """A figure whose up the motion misreads (a rig with IK bones near the ground read as
    legs) is written standing as the user says (``--up``), not on its side."""
    zup = ROOT / "tests" / "data" / "exporters" / "video2bvh_zup.bvh"
    hangers = {}
    for up in (None, "y"):
        target = tmp_path / f"{up}.gltf"
        code, _, err = run_cli(
            capsys, "convert", zup, target, *([] if up is None else ["--up", up])
        )
        assert code == 0, err
        document = json.loads(target.read_text())
        (top,) = document["scenes"][0]["nodes"]
        hangers[up] = document["nodes"][top]["name"]
        assert kinematics.up_name(mc.load(target)) == (up or "z")
    assert hangers == {None: "motionclean_up", "y": mc.load(zup).names[0]}


@pytest.mark.parametrize("up", ["z", "-y", "x"])
def test_a_skeleton_not_y_up_is_written_under_a_turn_that_stands_it_up(tmp_path, up):
    """glTF's up is +Y: a Z-up (or y-down, or X-up) clip keeps its own coordinates under a
    node turning its up onto +Y, so a viewer stands it upright (Blender's importer puts its
    head 135 units above its feet where it had lain on its side) and the reader finds the
    same up, body height and world positions (its own coordinates) again."""
    source = mc.load(ROOT / "tests" / "data" / "exporters" / "video2bvh_zup.bvh")
    target = {"z": [0.0, 0.0, 1.0], "-y": [0.0, -1.0, 0.0], "x": [1.0, 0.0, 0.0]}[up]
    turn = quat.normalize(np.concatenate([[1.0], np.cross([0.0, 0.0, 1.0], target)]))
    clip = turned_copy(source, turn)
    assert kinematics.up_name(clip) == up
    mc.save(clip, tmp_path / "c.gltf")
    document = json.loads((tmp_path / "c.gltf").read_text())
    (hanger,) = document["scenes"][0]["nodes"]
    x, y, z, w = document["nodes"][hanger]["rotation"]
    axis, sign = kinematics.up_direction(clip)
    head_up = np.zeros(3)
    head_up[axis] = sign
    np.testing.assert_allclose(quat.rotate(np.array([w, x, y, z]), head_up), [0, 1, 0], atol=1e-12)
    back = mc.load(tmp_path / "c.gltf")
    assert kinematics.up_name(back) == up and back.up == up  # given by the file
    assert kinematics.body_height(back) == pytest.approx(kinematics.body_height(clip), rel=1e-6)
    p_back, p_clip = kinematics.forward(back)[0], kinematics.forward(clip)[0]
    assert np.abs(p_back - p_clip).max() < 1e-4 * kinematics.body_height(clip)
    y_up = mc.load(SAMPLE)
    mc.save(y_up, tmp_path / "y.gltf")  # a Y-up clip: no extra node
    assert json.loads((tmp_path / "y.gltf").read_text())["scenes"][0]["nodes"] == [0]


@pytest.mark.parametrize("step", [3.3e-9, 7200.0])
def test_keys_at_no_usable_rate_are_refused_when_read(tmp_path, capsys, step):
    """Keys 3.3e-9 s apart had been read and cleaned, then refused by the writer naming the
    output file; keys two hours apart the same: refused on reading, as a BVH's Frame Time."""
    made = chain()
    grid = np.arange(0, 11) * step
    made.channel(0, "rotation", grid, z_turn(np.arange(0, 11) / 10.0))
    made.gltf(tmp_path / "odd.gltf")
    code, out, err = run_cli(capsys, "clean", tmp_path / "odd.gltf", "-o", tmp_path / "o.gltf")
    assert code == 1 and out == "" and err.count("\n") == 1
    assert err.startswith(f"motionclean: error: {tmp_path / 'odd.gltf'}: keys ")
    assert "no usable frame rate" in err and not (tmp_path / "o.gltf").exists()


def test_a_grid_far_larger_than_the_keys_is_refused_before_it_is_made(tmp_path, capsys):
    """One sampler's two keys 500 s apart beside keys 0.1 s apart make a grid of 5,001
    frames of 3 joints from 13 keys: refused on reading (one sampler's keys moved 5,000 s
    had made a 42 KB file take 3.3 GB); the same keys 1 s apart are read."""
    for span, name in ((500.0, "far.gltf"), (1.0, "near.gltf")):
        made = chain()
        grid = np.arange(0, 11) / 10.0
        made.channel(0, "rotation", grid, z_turn(grid))
        made.channel(1, "rotation", np.array([0.0, span]), z_turn(np.array([0.0, 0.5])))
        made.gltf(tmp_path / name)
    code, out, err = run_cli(capsys, "info", tmp_path / "far.gltf")
    assert code == 1 and out == "" and err.count("\n") == 1
    assert "5001 frames of 3 joints for 13 keys (at most 250 joint samples per key)" in err
    assert mc.load(tmp_path / "near.gltf").n_frames == 11


@pytest.mark.parametrize("broken", ["misspelt", "not a string", "twice", "twice elsewhere"])
def test_a_channel_with_a_bad_or_repeated_target_is_refused(tmp_path, capsys, broken):
    """A channel targeting "Rotation" or [0] had been dropped (its joint read at rest, no
    word), and a second channel on the same node and path had silently won (glTF allows
    one): each is one line naming the channel, exit 1. On a node outside the skeleton (a
    camera's) they are none of the clip's: read."""
    made = chain()
    if broken == "twice elsewhere":
        made.doc["nodes"].append({"name": "camera"})
        made.doc["scenes"][0]["nodes"].append(3)
        grid = np.arange(4) / 30.0
        made.channel(3, "rotation", grid, z_turn(0.1 * np.arange(4)))
        made.channel(3, "rotation", grid, z_turn(0.3 * np.arange(4)))
        made.channel(1, "rotation", grid, z_turn(0.1 * np.arange(4)))
        made.gltf(tmp_path / "c.gltf")
        code, _, err = run_cli(capsys, "info", tmp_path / "c.gltf")
        assert code == 0, err
        return
    grid = np.arange(4) / 30.0
    made.channel(1, "rotation", grid, z_turn(0.1 * np.arange(4)))
    made.channel(2, "rotation", grid, z_turn(0.2 * np.arange(4)))
    target = made.doc["animations"][0]["channels"][1]["target"]
    if broken == "misspelt":
        target["path"] = "Rotation"
    elif broken == "not a string":
        target["path"] = [0]
    else:
        target["node"] = 1
    made.gltf(tmp_path / "c.gltf")
    code, _, err = run_cli(capsys, "info", tmp_path / "c.gltf")
    assert code == 1 and err.count("\n") == 1
    if broken == "twice":
        assert "channels[0] and [1] both animate node 1's rotation" in err
    else:
        assert "animations[0].channels[1].target.path is" in err and "not one of" in err


def test_a_glb_s_rest_pose_is_its_nodes_rotations_and_offsets():
    """A glTF node's rotation is part of its rest: Blender's export stacks every bone along
    its node's y, and turned by the nodes' rotations its rest is the BVH's (offsets alone:
    the stack, extent 18.65 of 24.27). Its body height comes from its frames, as a rest
    posed by rotations is not measured (CesiumMan's folded offsets had read 0.27 m of
    1.13)."""
    glb, bvh = mc.load(BLENDER_GLB), mc.load(SAMPLE)
    height = kinematics.body_height(bvh)
    rest, folded = kinematics.rest_pose(glb), kinematics.rest_positions(glb)
    expected = kinematics.rest_positions(bvh)[: bvh.n_joints]
    assert np.abs(rest - expected).max() < 1e-4 * height
    assert np.abs(folded - expected).max() > 0.1 * height
    poses, _ = kinematics.sample_poses(glb)
    assert kinematics.body_height(glb) == pytest.approx(np.median(np.ptp(poses[..., 1], axis=1)))


def test_a_translation_track_still_within_float32_rounding_is_no_position_channel(tmp_path):
    """Blender keys every bone's translation at both ends, a few float32 units apart: such
    a bone has no position channels (it had read 186 channels of a 96-channel rig and
    rewritten each track at every frame); a track that truly moves keeps them."""
    times = np.arange(5) / 30.0
    made = chain()
    made.channel(1, "rotation", times, z_turn(np.linspace(0.0, 1.0, 5)))
    noisy = np.array([0.0, 1.0, 0.0]) + np.array([[0, 3e-7, 0], [0, -2e-7, 1e-7]] * 2 + [[0, 0, 0]])
    made.channel(2, "translation", times, noisy)
    made.gltf(tmp_path / "still.gltf")
    clip = mc.load(tmp_path / "still.gltf")
    assert not clip.layout.has_position[clip.names.index("tip")]
    moving = chain()
    moving.channel(1, "rotation", times, z_turn(np.linspace(0.0, 1.0, 5)))
    moving.channel(
        2, "translation", times, noisy + np.array([0.0, 0.01, 0.0]) * np.arange(5)[:, None]
    )
    moving.gltf(tmp_path / "moving.gltf")
    clip = mc.load(tmp_path / "moving.gltf")
    assert clip.layout.has_position[clip.names.index("tip")]
