#!/usr/bin/python3
"""Tables of bench/registration_findings.sh (run by it): reads the study folders it filled.

Signed distances use VTK's vtkImplicitPolyDataDistance on the true surfaces (negative inside).
"""
import csv
import json
import statistics
import sys

import vtk

work, registrations, fitted = sys.argv[1], int(sys.argv[2]), sys.argv[3]


def load_json(path):
    with open(path) as f:
        return json.load(f)


def surface(path):
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    distance = vtk.vtkImplicitPolyDataDistance()
    distance.SetInput(reader.GetOutput())
    return distance


def accepted_points(path):
    with open(path) as f:
        return [(float(r["x_mm"]), float(r["y_mm"]), float(r["z_mm"]))
                for r in csv.DictReader(f) if r["status"] == "accepted" and r["x_mm"]]


def transformed(m, p):
    return [sum(m[i][j] * p[j] for j in range(3)) + m[i][3] for i in range(3)]


def error_rows(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return rows[:-1], rows[-1]


def fmt(v, digits=2):
    return f"{float(v):.{digits}f}"


def registration_summary(paths):
    """Mean over the registrations of: inliers' RMS, mean signed residual of all points,
    points used / total, converged count."""
    rms, signed, used, total, ok = [], [], 0, 0, 0
    for p in paths:
        try:
            d = load_json(p)
        except FileNotFoundError:
            continue
        rms.append(d["rms_mm"])
        res = [q["residual_mm"] for q in d["points"]]
        signed.append(statistics.fmean(res))
        used += d["points_used"]
        total += len(res)
        ok += 1 if d["converged"] else 0
    return (statistics.fmean(rms) if rms else float("nan"),
            statistics.fmean(signed) if signed else float("nan"), used, total, ok)


def table(title, groups, target="hip_centre"):
    """groups: list of (label, errors csv, registration jsons); `target` names the distance column."""
    print(f"### {title}\n")
    head = f"| | registration | tx | ty | tz (mm) | rx | ry | rz (deg) | {target.replace('_', ' ')} (mm) | RMS (mm) | converged |"
    print(head)
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for label, errors, jsons in groups:
        rows, mean = error_rows(errors)
        names = {r["estimate"]: r for r in rows}
        for k, j in enumerate(jsons, 1):
            name = j.rsplit("/", 1)[-1]
            if name not in names:
                print(f"| {label} | #{k} | (no result) | | | | | | | | |")
                continue
            r = names[name]
            d = load_json(j)
            print(f"| {label} | #{k} | {fmt(r['tx_mm'])} | {fmt(r['ty_mm'])} | {fmt(r['tz_mm'])} | "
                  f"{fmt(r['rx_deg'])} | {fmt(r['ry_deg'])} | {fmt(r['rz_deg'])} | "
                  f"{fmt(r[f'target_{target}_mm'])} | {fmt(d['rms_mm'])} | {'yes' if d['converged'] else 'no'} |")
        used = [names[j.rsplit("/", 1)[-1]] for j in jsons if j.rsplit("/", 1)[-1] in names]
        mean = {key: statistics.fmean(abs(float(r[key])) for r in used) for key in
                ("tx_mm", "ty_mm", "tz_mm", "rx_deg", "ry_deg", "rz_deg", f"target_{target}_mm")} if used else mean
        print(f"| {label} | mean abs | {fmt(mean['tx_mm'])} | {fmt(mean['ty_mm'])} | {fmt(mean['tz_mm'])} | "
              f"{fmt(mean['rx_deg'])} | {fmt(mean['ry_deg'])} | {fmt(mean['rz_deg'])} | "
              f"{fmt(mean[f'target_{target}_mm'])} | | |")
    print()


# (a) Phantom.
ph = f"{work}/phantom"
print(f"## (a) Phantom in a water bath: speed of sound of the detection\n")
truth_water = load_json(f"{ph}/truth/calibration.json").get("water_speed_of_sound_mps")
print(f"Bath: {truth_water:.1f} m/s (truth); the capture assumes 1450 m/s; the calibration fitted "
      f"{fitted} m/s.\n")
print("| speed (m/s) | bone | points | signed distance at the truth, mean / median (mm) | "
      "signed residual after registration, mean (mm) | inliers' RMS (mm) | used / points | converged |")
print("|---|---|---|---|---|---|---|---|")
for speed in ("1450", "1540", fitted):
    for bone, Bone in (("femur", "Femur"), ("tibia", "Tibia")):
        dist = surface(f"{ph}/truth/{bone}.vtp")
        m = load_json(f"{ph}/truth/{Bone}ToCT.json")["matrix"]
        d_all = []
        for k in range(1, registrations + 1):
            for p in accepted_points(f"{ph}/results/{bone}_{speed}_{k}.csv"):
                d_all.append(dist.EvaluateFunction(transformed(m, p)))
        jsons = [f"{ph}/results/{bone}_{speed}_{k}.json" for k in range(1, registrations + 1)]
        rms, signed, used, total, ok = registration_summary(jsons)
        print(f"| {speed} | {bone} | {len(d_all)} | {statistics.fmean(d_all):+.2f} / {statistics.median(d_all):+.2f} | "
              f"{signed:+.2f} | {rms:.2f} | {used} / {total} | {ok} of {registrations} |")
print()
for bone, target in (("femur", "hip_centre"), ("tibia", "medial_malleolus")):
    table(f"Phantom {bone}: errors against the truth by detection speed", [
        (f"{speed} m/s", f"{ph}/results/errors_{bone}_{speed}.csv",
         [f"{ph}/results/{bone}_{speed}_{k}.json" for k in range(1, registrations + 1)])
        for speed in ("1450", "1540", fitted)], target)

# (b) Femur regions.
print("## (b) Femur: anterior distal femur and epicondyles vs the epicondyles only\n")
table("Femur errors, started from the two epicondyles (rotation about their line searched)", [
    (regions, f"{work}/{study}/results/errors_femur.csv",
     [f"{work}/{study}/results/femur_{k}.json" for k in range(1, registrations + 1)])
    for regions, study in (("all regions", "cad_all"), ("epicondyles", "cad_epicondyles"))])
print("The four landmarks of the straight leg in the femur marker's frame (echoreg landmarks), "
      "then the surface registration from there:\n")
for regions, study in (("all regions", "cad_all"), ("epicondyles", "cad_epicondyles")):
    rows, _ = error_rows(f"{work}/{study}/results/errors_femur_leg.csv")
    lm = rows[0]
    print(f"- {regions}: landmarks alone (FRE {load_json(f'{work}/{study}/results/femur_leg_landmarks.json')['fre_mm']:.1f} mm): "
          f"({fmt(lm['tx_mm'])}, {fmt(lm['ty_mm'])}, {fmt(lm['tz_mm'])}) mm, "
          f"({fmt(lm['rx_deg'])}, {fmt(lm['ry_deg'])}, {fmt(lm['rz_deg'])}) deg, hip centre {fmt(lm['target_hip_centre_mm'])} mm")
print()
table("Femur errors, started from the four landmarks of the straight leg", [
    (regions, f"{work}/{study}/results/errors_femur_leg.csv",
     [f"{work}/{study}/results/femur_leg_{k}.json" for k in range(1, registrations + 1)])
    for regions, study in (("all regions", "cad_all"), ("epicondyles", "cad_epicondyles"))])

# (c) Tibia model.
print("## (c) Tibia: registered to the tibia alone vs to the tibia and fibula\n")
table("Tibia errors against the truth (same points)", [
    (label, f"{work}/cad_all/results/errors_{model}.csv",
     [f"{work}/cad_all/results/{model}_{k}.json" for k in range(1, registrations + 1)])
    for label, model in (("tibia only", "tibia_only"), ("tibia + fibula", "tibia_fibula"))], "medial_malleolus")
shots = {}
with open(f"{work}/cad_all/truth/shots.csv") as f:
    for r in csv.DictReader(f):
        if r["capture"].startswith("tibia_ultrasound"):
            key = (r["bone"], r["should_accept"] == "1")
            shots[key] = shots.get(key, 0) + 1
print("Beams of the tibia sweeps by the bone they hit first (truth/shots.csv; accepted = a correct "
      "detector should accept): " + ", ".join(f"{b} {'accepted' if a else 'not accepted'}: {n}"
                                               for (b, a), n in sorted(shots.items())))
