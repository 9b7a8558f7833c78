#!/usr/bin/python3
"""Writes fuzz/seeds/dicom: small synthetic CT series (8 x 8 pixels) as fuzz_dicom reads them, the
files of a series joined by fuzz_input.hpp's kNextFile marker. Written once with pydicom (Debian's
python3-pydicom); the seeds are committed, so the fuzzer and the replay test need nothing of this.

    /usr/bin/python3 fuzz/make_dicom_seeds.py fuzz/seeds/dicom
"""
import io
import struct
import sys

import numpy as np
import pydicom
from pydicom.dataset import FileDataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, ImplicitVRLittleEndian, RLELossless

NEXT_FILE = b"\n--echoreg-fuzz-next-file--\n"
SERIES = "1.2.826.0.1.3680043.8.498.1"


def slice_bytes(z, rows=8, columns=8, syntax=ExplicitVRLittleEndian, signed=True, slope=1.0,
                intercept=-1024.0, orientation=(1, 0, 0, 0, 1, 0), instance=1):
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
    meta.MediaStorageSOPInstanceUID = f"{SERIES}.{instance}"
    meta.TransferSyntaxUID = ExplicitVRLittleEndian if syntax == RLELossless else syntax
    ds = FileDataset(None, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "CT"
    ds.SeriesInstanceUID = SERIES
    ds.StudyInstanceUID = SERIES + ".0"
    ds.SeriesDescription = "fuzz seed"
    ds.InstanceNumber = instance
    ds.ImagePositionPatient = [-4.0, -4.0, float(z)]
    ds.ImageOrientationPatient = list(orientation)
    ds.PixelSpacing = [0.5, 0.5]
    ds.SliceThickness = 1.0
    ds.Rows, ds.Columns = rows, columns
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 12, 11
    ds.PixelRepresentation = 1 if signed else 0
    ds.RescaleSlope, ds.RescaleIntercept = slope, intercept
    values = (np.arange(rows * columns).reshape(rows, columns) * 37 + int(z) * 101) % 4096
    ds.PixelData = values.astype(np.int16 if signed else np.uint16).tobytes()
    ds.is_little_endian = True
    ds.is_implicit_VR = syntax == ImplicitVRLittleEndian
    if syntax == RLELossless:
        ds.compress(RLELossless)
    out = io.BytesIO()
    ds.save_as(out, write_like_original=False)
    return out.getvalue()


def implicit_meta(data):
    """The same file with its file meta group written implicit (tag, 4-byte length, value), as GE's
    private syntax has it; GDCM reads such a group when its first element is not followed by a VR."""
    out, at = bytearray(data[:132]), 132
    while data[at:at + 2] == b"\x02\x00":
        long_vr = data[at + 4:at + 6] in (b"OB", b"UN", b"UT", b"UC", b"UR")
        value = at + (12 if long_vr else 8)
        length = int.from_bytes(data[at + (8 if long_vr else 6):value], "little")
        out += data[at:at + 4] + length.to_bytes(4, "little") + data[value:value + length]
        at = value + length
    return bytes(out + data[at:])


def with_rle_frame(data, frame):
    """The same RLE slice with its compressed frame (the pixel data's one fragment, after the basic
    offset table) replaced by `frame`."""
    at = data.index(b"\xe0\x7f\x10\x00OB\x00\x00\xff\xff\xff\xff") + 12
    assert data[at:at + 4] == b"\xfe\xff\x00\xe0"
    at += 8 + struct.unpack("<I", data[at + 4:at + 8])[0]
    assert data[at:at + 4] == b"\xfe\xff\x00\xe0"
    length = struct.unpack("<I", data[at + 4:at + 8])[0]
    frame += b"\x00" * (len(frame) % 2)
    return data[:at + 4] + struct.pack("<I", len(frame)) + frame + data[at + 8 + length:]


def rle_frame(segments, declared=None):
    """An RLE frame: the 64-byte header (the number of segments and their offsets), then them."""
    offsets, at = [], 64
    for segment in segments:
        offsets.append(at)
        at += len(segment)
    count = len(segments) if declared is None else declared
    return struct.pack("<16I", count, *(offsets + [0] * (15 - len(offsets)))) + b"".join(segments)


def literal(values):
    """A PackBits literal run of these bytes (1 to 128)."""
    return bytes([len(values) - 1]) + bytes(values)


def damaged_rle(frame):
    """Two RLE slices (8 x 8 pixels of 16 bits: two segments of 64 bytes), the second with this
    frame: Debian's GDCM 3.0 trusted RLE headers and aborted on some (see main)."""
    return [slice_bytes(0, syntax=RLELossless, instance=1),
            with_rle_frame(slice_bytes(1, syntax=RLELossless, instance=2), frame)]


def main(folder):
    seeds = {
        "one-slice": [slice_bytes(0)],
        "three-slices": [slice_bytes(z, instance=z + 1) for z in range(3)],
        "missing-slice": [slice_bytes(z, instance=z + 1) for z in (0, 1, 2, 4)],
        "implicit-unsigned": [slice_bytes(z, syntax=ImplicitVRLittleEndian, signed=False,
                                          slope=2.0, intercept=-2048.0, instance=z + 1)
                              for z in range(2)],
        "rle": [slice_bytes(z, syntax=RLELossless, instance=z + 1) for z in range(2)],
        "uneven-orientations": [slice_bytes(0), slice_bytes(1, orientation=(0, 1, 0, 1, 0, 0),
                                                            instance=2)],
        "implicit-meta": [implicit_meta(slice_bytes(z, instance=z + 1)) for z in range(2)],
        # Three segments of 42 bytes where the slice has 128: GDCM's assertion `check == len` in
        # gdcm::RLECodec::Decode aborted the process; no segment at all divided by zero (SIGFPE);
        # a first segment of 32 bytes was completed with the second's, a wrong slice read silently.
        "rle-damaged-segment-count": damaged_rle(rle_frame([literal(range(42))] * 3)),
        "rle-damaged-no-segment": damaged_rle(rle_frame([literal(range(64))] * 2, declared=0)),
        "rle-damaged-short-segment": damaged_rle(
            rle_frame([literal(range(32)), literal(range(100, 132)) * 2])),
    }
    for name, files in seeds.items():
        with open(f"{folder}/{name}.dcm-series", "wb") as out:
            out.write(NEXT_FILE.join(files))


if __name__ == "__main__":
    main(sys.argv[1])
