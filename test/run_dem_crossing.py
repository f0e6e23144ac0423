#!/usr/bin/python3
"""The DEM contact mode end to end (issue 25, items 1, 3 and 5): config/scenarios/dem_crossing.yaml
(the tracer_x crossing a 4.8 m DEM segment on a patch per side) through
launch/reference_traverse.launch on a private master, as a user runs it. Writes a JUnit XML
result:

- run_exits_0: the run ends by itself with exit 0 within the wall limit;
- crossing_in_summary: summary.json's vehicles[0].dem is there: the crossing began and ended
  within the run, the patches moved exactly 60 times (two sides, each 1.2 m patch moving in
  0.12 m blocks from 3.2 m to the segment's end at 6.8 m: 30 each), and the soil took work;
- rut_in_the_terrain: rut_depth.npy along both wheel tracks inside the segment (x in [2.6, 6.2]
  m, y within 3 cm of +-0.31 m) is deeper than 5 mm on average: the patches wrote it back,
  /terrain/ruts carried it to run_recorder.

usage: run_dem_crossing.py LAUNCH_FILE SCENARIO RESULT_XML [WALL_LIMIT_S]
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback

import numpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scripted_tests import free_port, stop_launch, write_junit  # noqa: E402


def main(argv):
    if len(argv) < 4:
        sys.stderr.write(__doc__)
        return 2
    launch_file, scenario, result = argv[1], os.path.abspath(argv[2]), argv[3]
    limit = float(argv[4]) if len(argv) > 4 else 240.0
    tmp = tempfile.mkdtemp(prefix="avsp_dem_")
    out = os.path.join(tmp, "results")
    cases = []
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_IP="127.0.0.1")
    env.pop("ROS_HOSTNAME", None)
    log = open(os.path.join(tmp, "launch.log"), "w")
    launch = None
    try:
        start = time.time()
        launch = subprocess.Popen(["roslaunch", "-p", str(port), launch_file, "scenario:=" + scenario,
                                   "duration:=13", "real_time_factor:=0", "output_dir:=" + out],
                                  env=env, stdout=log, stderr=subprocess.STDOUT, preexec_fn=os.setsid)
        try:
            rc = launch.wait(timeout=limit)
        except subprocess.TimeoutExpired:
            rc = None
        print("run_dem_crossing: %.1f s wall, exit %s" % (time.time() - start, rc))
        log.flush()
        with open(os.path.join(tmp, "launch.log")) as f:
            tail = f.read()[-800:]
        cases.append(("run_exits_0", [] if rc == 0 else ["exit %s: %s" % (rc, tail)]))

        msgs = []
        try:
            with open(os.path.join(out, "summary.json")) as f:
                doc = json.load(f)
            dem = doc["vehicles"][0].get("dem")
            if dem is None:
                msgs.append("no vehicles[0].dem in summary.json")
            else:
                print("run_dem_crossing: dem %s" % json.dumps(dem, sort_keys=True))
                if not 0.0 < dem["entered"] < dem["left"] <= 13.0:
                    msgs.append("entered %s, left %s: not a crossing within the run" % (dem["entered"], dem["left"]))
                if dem["patch_moves"] != 60:
                    msgs.append("patch_moves %s, expected 60" % dem["patch_moves"])
                if not dem["energy"] > 0.0:
                    msgs.append("energy %s J: the wheels did no work on the soil" % dem["energy"])
                if not dem["points_written"] > 0:
                    msgs.append("no terrain point written back")
        except Exception as e:  # noqa: BLE001
            msgs.append("summary unreadable: %s" % e)
        cases.append(("crossing_in_summary", msgs))

        msgs = []
        try:
            with open(os.path.join(out, "grids.json")) as f:
                g = json.load(f)["ruts"]
            depth = numpy.load(os.path.join(out, g["file"]))
            means = []
            for y_track in (-0.31, 0.31):
                cells = []
                for j in range(depth.shape[0]):
                    y = g["origin_y"] + j * g["resolution"]
                    if abs(y - y_track) > 0.03:
                        continue
                    for i in range(depth.shape[1]):
                        x = g["origin_x"] + i * g["resolution"]
                        if 2.6 <= x <= 6.2:
                            v = depth[j, i]
                            cells.append(0.0 if numpy.isnan(v) else float(v))
                if not cells:
                    msgs.append("no rut grid cells along y = %g" % y_track)
                    continue
                means.append(sum(cells) / len(cells))
            print("run_dem_crossing: mean rut depth along the tracks in the segment %s m" % means)
            if any(m <= 0.005 for m in means):
                msgs.append("mean rut depths %s m: not deeper than 5 mm" % means)
        except Exception as e:  # noqa: BLE001
            msgs.append("rut grid unreadable: %s" % e)
        cases.append(("rut_in_the_terrain", msgs))
    except Exception:  # noqa: BLE001
        cases.append(("harness", [traceback.format_exc()]))
    finally:
        if launch is not None:
            stop_launch(launch)
        log.close()
        shutil.rmtree(tmp, ignore_errors=True)
    write_junit(result, "dem_crossing", cases)
    return 0 if all(not m for _n, m in cases) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
