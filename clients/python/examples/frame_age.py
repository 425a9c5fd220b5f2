#!/usr/bin/env python3
"""How old each frame is when a Python client holds it: the age from the server's publish time
(`FrameHeader.publish_unix_ns`) to the moment the client has the frame as a numpy array, the
frames received per second and the frames missed (gaps in `frame_index`), over shared memory or
through `splatphys-zenoh`. Both clocks are the host's wall clock: across machines, synchronise
them (chrony, PTP) or read the ages as offsets.

    splatphys serve scenes/donut_drop.toml --realtime &
    splatphys-zenoh --prefix splatphys/donut_drop &
    python3 clients/python/examples/frame_age.py --prefix splatphys/donut_drop --transport zenoh

Prints one JSON line; with `--max-age-ms` exits 1 when any frame was older than that.
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import splatphys_client as sc  # noqa: E402


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--prefix", default=os.environ.get("SPLATPHYS_PREFIX", "splatphys/default"),
                   help="service prefix of the server")
    p.add_argument("--transport", choices=["shm", "zenoh"], default="shm")
    p.add_argument("--connect", action="append", default=None,
                   help="Zenoh endpoint of the bridge (repeatable; default tcp/127.0.0.1:7447)")
    p.add_argument("--seconds", type=float, default=10.0, help="how long to listen, s")
    p.add_argument("--max-age-ms", type=float, default=None, help="fail when a frame is older")
    a = p.parse_args(argv)
    if a.transport == "zenoh":
        client = sc.ZenohClient(a.prefix, connect=a.connect or [sc.zenoh_client.DEFAULT_ENDPOINT],
                                objects=False, commands=False, frame_buffer=1, connect_timeout_s=10.0)
    else:
        client = sc.Client(a.prefix, objects=False, commands=False, frame_buffer=1, connect_timeout_s=10.0)
    ages_ms, indices, counts = [], [], set()
    start = time.monotonic()
    while time.monotonic() - start < a.seconds:
        f = client.latest_frame()
        if f is None:
            client.wait(0.0005)
            continue
        with f:
            positions = f.gaussians["position_m"]
            held_ns = time.time_ns()
            ages_ms.append((held_ns - f.header.publish_unix_ns) / 1e6)
            indices.append(f.header.frame_index)
            counts.add(int(positions.shape[0]))
    client.close()
    if len(indices) < 2:
        print(json.dumps({"error": f"{len(indices)} frames in {a.seconds} s"}))
        return 1
    span = indices[-1] - indices[0] + 1
    ages = np.array(ages_ms)
    out = {
        "transport": a.transport,
        "gaussians": sorted(counts),
        "frames_received": len(indices),
        "frames_published": int(span),
        "frames_missed": int(span - len(indices)),
        "received_per_s": len(indices) / a.seconds,
        "age_ms_p50": float(np.percentile(ages, 50)),
        "age_ms_p99": float(np.percentile(ages, 99)),
        "age_ms_max": float(ages.max()),
    }
    print(json.dumps(out))
    if a.max_age_ms is not None and out["age_ms_max"] > a.max_age_ms:
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
