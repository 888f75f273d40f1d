r"""KTX 2.0 files of uncompressed float texels: one 2-D image, one mip level, no supercompression.

Written to the Khronos KTX File Format Specification, version 2.0 (the ``ktxspec.adoc`` of
KhronosGroup/KTX-Specification; "KTX §n" below are its section numbers) and to the Khronos Data Format
Specification 1.4 that its data format descriptor defers to ("KDFS §n"; the basic descriptor block is its
chapter 5).  The file is, in order:

* the 80-byte header: identifier, vkFormat, typeSize, the size, layer, face and level counts, the
  supercompression scheme, and the index of the data format descriptor, the key/value data and the
  supercompression global data (KTX §2, §3.1 to §3.9);
* the level index: one entry, the base level (KTX §3.9.7);
* the data format descriptor: its total size and one basic descriptor block, a float sample per channel
  (KTX §3.10, KDFS §4 and §5);
* the key/value data, sorted by key, each pair padded to 4 bytes (KTX §3.11);
* zero bytes up to the level's alignment, then the texels, rows tightly packed from the first row,
  little-endian (KTX §3.13, §4.5, §4.6).

The formats are ``VK_FORMAT_R32_SFLOAT``, ``R32G32_SFLOAT``, ``R32G32B32A32_SFLOAT`` and their 16-bit
half-float counterparts (:data:`VK_FORMATS`).  A three-channel table is written as four channels with A = 1
(:func:`encode`): the three-component formats exist in Vulkan, but the format mapping that the KTX
specification itself publishes (its ``formats.json``, KTX appendix B) has no Metal format for
``R32G32B32_SFLOAT`` and neither a Metal nor a DXGI format for ``R16G16B16_SFLOAT``, so a loader on those APIs
would have to repack the texels; four channels upload as they are everywhere.
"""

from __future__ import annotations

import math
import struct

import numpy as np

__all__ = ["VK_FORMATS", "IDENTIFIER", "encode"]

#: KTX §3.1: the file identifier, "«KTX 20»\r\n\x1A\n"
IDENTIFIER = bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A])
#: (bytes per component, channels) -> the VkFormat enumerant (Vulkan's ``VkFormat``; KTX §3.2)
VK_FORMATS = {(4, 1): 100, (4, 2): 103, (4, 4): 109, (2, 1): 76, (2, 2): 83, (2, 4): 97}

# KDFS §5.5, §5.7, §5.8: the colour model, primaries and transfer function of the basic descriptor block
_KHR_DF_MODEL_RGBSDA = 1
_KHR_DF_PRIMARIES_BT709 = 1
_KHR_DF_TRANSFER_LINEAR = 1
# KDFS §5.5 (the RGBSDA channels) and §5.15 (the qualifier bits of a sample's channelType)
_CHANNEL_IDS = {1: (0,), 2: (0, 1), 4: (0, 1, 2, 15)}  # red, green, blue, alpha
_QUALIFIER_FLOAT = 0x80
_QUALIFIER_SIGNED = 0x40
# KDFS §5.17: a float sample's sampleLower and sampleUpper are floats, -1.0 and 1.0, as float32 bit patterns
# for half samples too (KDFS chapter 11, "a standard signed 16-bit floating-point red value, described normally")
_SAMPLE_LOWER = struct.unpack("<I", struct.pack("<f", -1.0))[0]
_SAMPLE_UPPER = struct.unpack("<I", struct.pack("<f", 1.0))[0]
#: the largest finite half float
_HALF_MAX = 65504.0


def _data_format_descriptor(component_bytes: int, channels: int) -> bytes:
    """KTX §3.10 and KDFS §4, §5: dfdTotalSize, then one basic descriptor block with a sample per channel."""
    samples = _CHANNEL_IDS[channels]
    block_size = 24 + 16 * len(samples)  # KDFS §5.4
    words = [
        0,  # KDFS §5.1, §5.2: vendorId 0 (Khronos) in bits 0-16, descriptorType 0 (basic) in bits 17-31
        2 | block_size << 16,  # KDFS §5.3, §5.4: versionNumber 2, descriptorBlockSize
        # KDFS §5.5, §5.7, §5.8, §5.9: colour model, primaries, transfer function, flags 0 (alpha straight)
        _KHR_DF_MODEL_RGBSDA | _KHR_DF_PRIMARIES_BT709 << 8 | _KHR_DF_TRANSFER_LINEAR << 16,
        0,  # KDFS §5.10: texelBlockDimension0..3 = 0, a block of 1 x 1 x 1 x 1 texels
        component_bytes * channels,  # KDFS §5.11: bytesPlane0, one plane; bytesPlane1..3 = 0
        0,  # bytesPlane4..7 = 0
    ]
    for k, channel_id in enumerate(samples):
        channel_type = channel_id | _QUALIFIER_FLOAT | _QUALIFIER_SIGNED  # KDFS §5.15: an IEEE float is signed
        # KDFS §5.12 to §5.14: bitOffset in bits 0-15, bitLength - 1 in bits 16-23, channelType in bits 24-31
        words.append(k * 8 * component_bytes | (8 * component_bytes - 1) << 16 | channel_type << 24)
        words += [0, _SAMPLE_LOWER, _SAMPLE_UPPER]  # KDFS §5.16: samplePosition0..3 = 0; KDFS §5.17
    block = struct.pack(f"<{len(words)}I", *words)
    return struct.pack("<I", 4 + len(block)) + block  # KTX §3.10.4: dfdTotalSize counts itself


def _key_value_data(pairs: dict[str, bytes]) -> bytes:
    """KTX §3.11: keyAndValueByteLength, the key and its NUL, the value, then valuePadding to 4 bytes; the pairs
    sorted by the Unicode code points of their keys (byte order of UTF-8 is code point order)."""
    out = b""
    for key in sorted(pairs):
        encoded = key.encode("utf-8")
        if not encoded or b"\0" in encoded:
            raise ValueError(f"a KTX2 key must be non-empty text without NUL, not {key!r}")
        entry = encoded + b"\0" + pairs[key]
        out += struct.pack("<I", len(entry)) + entry + bytes(-len(entry) % 4)  # KTX §3.11.1 to §3.11.3
    return out


def _text(value: str) -> bytes:
    """KTX §3.11.2: a UTF-8 value, NUL-terminated (the NUL counted in keyAndValueByteLength)."""
    if "\0" in value:
        raise ValueError("a KTX2 text value holds a NUL")
    return value.encode("utf-8") + b"\0"


def encode(data, component_bytes: int, key_values: dict[str, str]) -> bytes:
    """The KTX2 file of ``data`` (height, width, 1 to 4 channels; row 0 first), its components float32
    (``component_bytes`` 4) or half (2), with ``key_values`` (text; keys starting with "KTX" are the
    specification's own: KTXorientation, KTXwriter, ...).  Three channels are stored as four with A = 1 (the
    module docstring says why).  Half floats are refused beyond 65504 (they would be infinite)."""
    data = np.asarray(data, dtype=np.float64)
    if data.ndim != 3 or not 1 <= data.shape[2] <= 4 or 0 in data.shape:
        raise ValueError(f"a KTX2 image is (height, width, 1 to 4 channels), not {data.shape}")
    if component_bytes not in (2, 4):
        raise ValueError(f"KTX2 components are 4-byte or 2-byte floats, not {component_bytes}-byte")
    if not np.all(np.isfinite(data)):
        raise ValueError("a KTX2 texel is not finite")
    if component_bytes == 2 and np.abs(data).max() > _HALF_MAX:
        raise ValueError(f"a value beyond {_HALF_MAX:g}, the largest half float")
    height, width, channels = data.shape
    if channels == 3:
        data = np.concatenate((data, np.ones((height, width, 1))), axis=2)
        channels = 4
    vk_format = VK_FORMATS[component_bytes, channels]
    texels = np.ascontiguousarray(data.astype("<f4" if component_bytes == 4 else "<f2")).tobytes()

    dfd = _data_format_descriptor(component_bytes, channels)
    kvd = _key_value_data({key: _text(value) for key, value in key_values.items()})
    header_bytes = 12 + 4 * 9 + 4 * 4 + 8 * 2  # KTX §2: identifier, 9 UInt32 fields, the index (80 bytes)
    level_index_bytes = 3 * 8  # KTX §3.9.7: byteOffset, byteLength, uncompressedByteLength of one level
    dfd_offset = header_bytes + level_index_bytes
    kvd_offset = dfd_offset + len(dfd)  # KTX §3.10.4: the key/value data follow the descriptor at once
    # KTX §3.13.2: mipPadding aligns the level to lcm(texel block size, 4); no supercompression global data
    # (KTX §3.12), so nothing else comes between
    alignment = math.lcm(component_bytes * channels, 4)
    level_offset = -(-(kvd_offset + len(kvd)) // alignment) * alignment
    header = IDENTIFIER + struct.pack(
        "<9I4I2Q",
        vk_format,  # KTX §3.2
        component_bytes,  # KTX §3.3: typeSize, the bytes of one component of an unpacked format
        width,
        height,
        0,  # KTX §3.4: pixelDepth 0, a 2-D texture (KTX §4.1)
        0,  # KTX §3.5: layerCount 0, not an array
        1,  # KTX §3.6: faceCount 1, not a cubemap
        1,  # KTX §3.7: levelCount 1, the base level only and no other levels meant (a table, not a picture)
        0,  # KTX §3.8: supercompressionScheme 0, none
        dfd_offset,  # KTX §3.9.1
        len(dfd),  # KTX §3.9.2: dfdByteLength = dfdTotalSize
        kvd_offset if kvd else 0,  # KTX §3.9.3: 0 where there are no key/value data
        len(kvd),  # KTX §3.9.4
        0,  # KTX §3.9.5, §3.9.6: no supercompression global data
        0,
    )
    # KTX §3.9.7.1 to §3.9.7.3: without supercompression byteLength = uncompressedByteLength
    level_index = struct.pack("<3Q", level_offset, len(texels), len(texels))
    head = header + level_index + dfd + kvd
    return head + bytes(level_offset - len(head)) + texels
