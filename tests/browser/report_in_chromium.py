#!/usr/bin/python3
"""The study report and the comparison report rendered by headless Chromium (Debian's chromium).

Runs the fixture study (a copy, the manifest's models), copies its results as a second study with
gel standoff, compares the two, and screenshots each report.html, and each again with its figures
folder removed. Checks, on the screenshots: the page is not blank; the tables are laid out (one
horizontal line of the tables' #ccc border per row and per table, as the HTML has them); the
figures loaded (the page with them is taller and holds many more coloured pixels than without
them); and that nothing was fetched from the network: every src/href of the HTML is a relative
path to a file beside it, and Chromium's net log holds no request to a host other than Chromium's
own background services. Skips (exit 77) without chromium or the fixture study.

Usage: report_in_chromium.py ECHOREG FIXTURE_STUDY WORKDIR
"""
import json
import os
import re
import shutil
import subprocess
import sys

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
# Chromium's own background requests (time, updates, accounts, models), not the page's.
CHROMIUM_OWN_HOSTS = ("google.com", "googleapis.com", "gvt1.com", "gstatic.com")


def skip(message):
    print(message + ": skipping the browser test")
    sys.exit(77)


def fail(message):
    print("FAIL: " + message, file=sys.stderr)
    sys.exit(1)


def screenshot(html, png, netlog):
    command = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
               "--no-first-run", "--disable-background-networking", "--disable-component-update",
               "--disable-sync", "--disable-extensions", "--window-size=1280,12000",
               "--host-resolver-rules=MAP * ~NOTFOUND", f"--log-net-log={netlog}",
               f"--screenshot={png}", "file://" + os.path.abspath(html)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=180)
    if done.returncode != 0 or not os.path.isfile(png):
        fail(f"chromium did not screenshot {html}: {done.stderr[-2000:]}")


def pixels(png):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    reader = vtk.vtkPNGReader()
    reader.SetFileName(png)
    reader.Update()
    image = reader.GetOutput()
    width, height, _ = image.GetDimensions()
    channels = image.GetNumberOfScalarComponents()
    rgb = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(height, width, channels)
    return rgb[::-1, :, :3].astype(int)  # the top row first


def measure(png):
    import numpy as np
    rgb = pixels(png)
    ink = rgb.min(axis=2) < 250
    rows = np.where(ink.any(axis=1))[0]
    coloured = (rgb.max(axis=2) - rgb.min(axis=2)) > 60
    border = (rgb[:, :, 0] == 204) & (rgb[:, :, 1] == 204) & (rgb[:, :, 2] == 204)
    lines = int((border.sum(axis=1) > 100).sum())
    return {"ink": float(ink.mean()), "bottom": int(rows.max()) if len(rows) else 0,
            "coloured": int(coloured.sum()), "border_lines": lines}


def check_offline(html):
    text = open(html, encoding="utf-8").read()
    folder = os.path.dirname(html)
    for link in re.findall(r'(?:src|href)="([^"]*)"', text):
        if re.match(r"^[a-z][a-z0-9+.-]*:", link) or link.startswith("//") or link.startswith("/"):
            fail(f"{html} links {link}: not a relative path (it would be fetched)")
        if not os.path.isfile(os.path.join(folder, link)):
            fail(f"{html} links {link}, which is not beside it")
    return text


def check_netlog(netlog):
    urls = set(re.findall(r'"url":"(https?://[^"/]*)', open(netlog, encoding="utf-8").read()))
    for url in urls:
        host = url.split("://", 1)[1].split(":")[0]
        if not any(host == h or host.endswith("." + h) for h in CHROMIUM_OWN_HOSTS):
            fail(f"{netlog}: the page fetched {url}")


def check_report(html, work, name):
    text = check_offline(html)
    shot = os.path.join(work, name + ".png")
    screenshot(html, shot, os.path.join(work, name + ".netlog.json"))
    check_netlog(os.path.join(work, name + ".netlog.json"))
    with_figures = measure(shot)
    # The same page without its figures: what a report whose images did not load looks like.
    bare_folder = os.path.join(work, name + "-without-figures")
    shutil.copytree(os.path.dirname(html), bare_folder, symlinks=True,
                    ignore=shutil.ignore_patterns("figures"))
    bare_shot = os.path.join(work, name + "-without-figures.png")
    screenshot(os.path.join(bare_folder, os.path.basename(html)), bare_shot,
               os.path.join(work, name + "-without-figures.netlog.json"))
    without = measure(bare_shot)
    print(f"{name}: with figures {with_figures}, without {without}")
    if with_figures["ink"] < 0.01:
        fail(f"{name}: the screenshot is blank ({with_figures})")
    # Tables: a border line above each row and below each table (collapsed borders).
    expected_lines = text.count("<tr>") + text.count("<table>")
    if not 0.9 * expected_lines <= with_figures["border_lines"] <= expected_lines + 2:
        fail(f"{name}: {with_figures['border_lines']} table border lines on the screenshot, the "
             f"HTML has {text.count('<table>')} tables of {text.count('<tr>')} rows")
    if with_figures["bottom"] >= 11990:
        fail(f"{name}: the page is longer than the 12000-pixel window; raise it")
    figures = text.count("<img ")
    if figures == 0:
        fail(f"{name}: the report has no figure")
    if with_figures["bottom"] - without["bottom"] < 150 * figures:
        fail(f"{name}: the {figures} figures add {with_figures['bottom'] - without['bottom']} "
             "pixels of height: not loaded?")
    if with_figures["coloured"] < 2000 or with_figures["coloured"] < 5 * max(without["coloured"], 1):
        fail(f"{name}: {with_figures['coloured']} coloured pixels with the figures, "
             f"{without['coloured']} without: the figures did not load")


def main():
    if len(sys.argv) != 4:
        print(__doc__)
        sys.exit(2)
    echoreg, fixture, work = sys.argv[1:]
    if CHROMIUM is None:
        skip("chromium is not installed (scripts/install-deps --browser)")
    if not os.path.isfile(os.path.join(fixture, "study.json")):
        skip(f"the fixture study {fixture} is absent (ctest -R simulate_fixture_study)")
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    glove = os.path.join(work, "glove")
    shutil.copytree(fixture, glove, ignore=shutil.ignore_patterns("results"))
    run = subprocess.run([echoreg, "study", "run", glove, "--given-models"], capture_output=True,
                         text=True)
    if run.returncode != 0:
        fail("study run: " + run.stderr)
    gel = os.path.join(work, "gel")
    shutil.copytree(glove, gel)
    manifest = json.load(open(os.path.join(gel, "study.json")))
    manifest["generator"]["standoff"] = "gel"
    json.dump(manifest, open(os.path.join(gel, "study.json"), "w"), indent=2)
    compare = os.path.join(work, "compare")
    run = subprocess.run([echoreg, "study", "compare", glove, gel, "--out", compare, "--group-by",
                          "generator.standoff"], capture_output=True, text=True)
    if run.returncode != 0:
        fail("study compare: " + run.stderr)
    check_report(os.path.join(glove, "results", "report.html"), work, "study")
    check_report(os.path.join(compare, "report.html"), work, "compare")
    print("browser: the study and the comparison reports laid out with their figures, offline")


if __name__ == "__main__":
    main()
