#!/usr/bin/python3
"""Independent reference for the DICOM series reader (pydicom, not GDCM).

Usage: read_ct_reference.py FOLDER|FILE [I,J,K ...]

Reads every file of FOLDER that pydicom can read as an image, sorts the slices by
ImagePositionPatient . (row x column), and prints one JSON object: the first slice's position
(origin), the row / column / normal directions, the pixel spacing (along i = columns, along j =
rows), the slice positions along the normal relative to the first, the file names in slice order,
and the HU of voxels I,J,K (column, row, sorted slice index) = stored * RescaleSlope +
RescaleIntercept.
"""
import json
import os
import sys

import pydicom


def main():
    folder = sys.argv[1]
    slices = []
    names = sorted(os.listdir(folder)) if os.path.isdir(folder) else [os.path.basename(folder)]
    if not os.path.isdir(folder):
        folder = os.path.dirname(folder)
    for name in names:
        try:
            ds = pydicom.dcmread(os.path.join(folder, name))
        except Exception:  # not DICOM: the reader skips it too
            continue
        if "Rows" not in ds or "ImagePositionPatient" not in ds:
            continue
        slices.append((name, ds))
    o = [float(v) for v in slices[0][1].ImageOrientationPatient]
    row, col = o[:3], o[3:]
    normal = [row[1] * col[2] - row[2] * col[1],
              row[2] * col[0] - row[0] * col[2],
              row[0] * col[1] - row[1] * col[0]]

    def along(ds):
        return sum(float(p) * n for p, n in zip(ds.ImagePositionPatient, normal))

    slices.sort(key=lambda item: along(item[1]))
    first = slices[0][1]
    spacing = [float(v) for v in first.PixelSpacing]
    voxels = []
    for spec in sys.argv[2:]:
        i, j, k = (int(v) for v in spec.split(","))
        ds = slices[k][1]
        stored = int(ds.pixel_array[j, i])
        voxels.append({"i": i, "j": j, "k": k,
                       "hu": stored * float(ds.RescaleSlope) + float(ds.RescaleIntercept)})
    json.dump({
        "origin": [float(v) for v in first.ImagePositionPatient],
        "row": row, "column": col, "normal": normal,
        "spacing": [spacing[1], spacing[0]],
        "rows": int(first.Rows), "columns": int(first.Columns),
        "positions": [along(ds) - along(first) for _, ds in slices],
        "files": [name for name, _ in slices],
        "voxels": voxels,
    }, sys.stdout)


if __name__ == "__main__":
    main()
