#!/usr/bin/python3
"""Independent read-back of a CT series written by echoreg (pydicom, not GDCM).

Usage: read_dicom_series.py FOLDER [I,J,K ...]

Prints one JSON object: the geometry of every file (sorted by InstanceNumber) and the HU of the
voxels I,J,K (column, row, slice index) computed as stored * RescaleSlope + RescaleIntercept.
"""
import json
import os
import sys

import pydicom


def floats(value):
    return [float(v) for v in value]


def main():
    folder = sys.argv[1]
    datasets = []
    for name in sorted(os.listdir(folder)):
        ds = pydicom.dcmread(os.path.join(folder, name))
        datasets.append((name, ds))
    datasets.sort(key=lambda item: int(item[1].InstanceNumber))
    slices = []
    for name, ds in datasets:
        slices.append({
            "file": name,
            "transferSyntax": str(ds.file_meta.TransferSyntaxUID),
            "sopClass": str(ds.SOPClassUID),
            "sopInstance": str(ds.SOPInstanceUID),
            "mediaStorageSopInstance": str(ds.file_meta.MediaStorageSOPInstanceUID),
            "study": str(ds.StudyInstanceUID),
            "series": str(ds.SeriesInstanceUID),
            "frameOfReference": str(ds.FrameOfReferenceUID),
            "modality": str(ds.Modality),
            "instance": int(ds.InstanceNumber),
            "rows": int(ds.Rows),
            "columns": int(ds.Columns),
            "position": floats(ds.ImagePositionPatient),
            "orientation": floats(ds.ImageOrientationPatient),
            "pixelSpacing": floats(ds.PixelSpacing),
            "thickness": float(ds.SliceThickness),
            "location": float(ds.SliceLocation),
            "bitsAllocated": int(ds.BitsAllocated),
            "bitsStored": int(ds.BitsStored),
            "pixelRepresentation": int(ds.PixelRepresentation),
            "photometric": str(ds.PhotometricInterpretation),
            "intercept": float(ds.RescaleIntercept),
            "slope": float(ds.RescaleSlope),
            "rescaleType": str(ds.RescaleType),
            "kvp": float(ds.KVP),
        })
    voxels = []
    arrays = {}
    for spec in sys.argv[2:]:
        i, j, k = (int(v) for v in spec.split(","))
        if k not in arrays:
            arrays[k] = datasets[k][1].pixel_array  # rows x columns
        ds = datasets[k][1]
        stored = int(arrays[k][j, i])
        hu = stored * float(ds.RescaleSlope) + float(ds.RescaleIntercept)
        voxels.append({"i": i, "j": j, "k": k, "hu": hu})
    json.dump({"slices": slices, "voxels": voxels}, sys.stdout)


if __name__ == "__main__":
    main()
