#!/usr/bin/python3
"""Wraps export_records' raw A-lines as a PLUS sequence, so `echoreg detect` can run on them.

    /usr/bin/python3 bench/records_to_capture.py RECORDS.u8 CAPTURE.igs.mha [--samples 4096]

RECORDS.u8 is N x SAMPLES uint8, row-major (one A-line per row). CAPTURE is a MetaImage PLUS
sequence with DimSize = SAMPLES 1 N, uint8, one timestamp per frame (50 Hz) and echoreg's
acquisition keys (50 MHz, 1540 m/s, no delay): the records exactly, nothing else.
"""
import argparse
import pathlib
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("records", type=pathlib.Path)
    parser.add_argument("capture", type=pathlib.Path)
    parser.add_argument("--samples", type=int, default=4096)
    args = parser.parse_args()
    data = args.records.read_bytes()
    if args.samples <= 0 or len(data) % args.samples:
        raise SystemExit(f"{args.records}: {len(data)} bytes is not a whole number of "
                         f"{args.samples}-sample records")
    frames = len(data) // args.samples
    header = [
        "ObjectType = Image", "NDims = 3", "BinaryData = True", "BinaryDataByteOrderMSB = False",
        "CompressedData = False", f"DimSize = {args.samples} 1 {frames}",
        "ElementSpacing = 1 1 1", "Offset = 0 0 0", "TransformMatrix = 1 0 0 0 1 0 0 0 1",
        "ElementType = MET_UCHAR", "UltrasoundImageOrientation = MF",
        "UltrasoundImageType = BRIGHTNESS", "EchoregSamplingFrequencyHz = 50000000",
        "EchoregSpeedOfSoundMps = 1540", "EchoregDelayS = 0",
    ]
    header += [f"Seq_Frame{f:04d}_Timestamp = {f * 0.02:.3f}" for f in range(frames)]
    header.append("ElementDataFile = LOCAL")
    temporary = args.capture.with_name(args.capture.name + ".tmp")
    with open(temporary, "wb") as out:
        out.write(("\n".join(header) + "\n").encode("ascii"))
        out.write(data)
    temporary.replace(args.capture)
    print(f"{args.capture}: {frames} frames of {args.samples} samples")
    return 0


if __name__ == "__main__":
    sys.exit(main())
