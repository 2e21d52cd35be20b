"""The reference for `cargo bench -p speleo-slam --bench registration -- real_pair/`:
PyPI small_gicp (1.0.1) registering the same real HDL-32E pair (frame 8 onto
frame 9 of ../shared/data/velodyne/monterey-first-100-packets.pcap) with the
same downsampling, on one thread, timed the same way (median of repeated
runs, preprocessing of both clouds included).

    speleo decode hdl32e monterey-first-100-packets.pcap --frame 8 --csv f8.csv
    speleo decode hdl32e monterey-first-100-packets.pcap --frame 9 --csv f9.csv
    python3 -m venv venv && venv/bin/pip install numpy small_gicp==1.0.1
    venv/bin/python small_gicp_reference.py f8.csv f9.csv

Compare its medians with `real_pair/prepare_both_and_align` and
`real_pair/prepare_one` measured in the same session.
"""

import statistics
import sys
import time

import numpy as np
import small_gicp


def load(path):
    xyz = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    return np.ascontiguousarray(xyz, dtype=np.float64)


def median_ms(f, runs=30):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e3


def main():
    source, target = load(sys.argv[1]), load(sys.argv[2])
    result = small_gicp.align(
        target, source, downsampling_resolution=0.25, num_threads=1, registration_type="GICP"
    )
    print(f"{len(source)} + {len(target)} points, converged {result.converged}")
    print("T_target_source:\n", result.T_target_source)
    align_ms = median_ms(
        lambda: small_gicp.align(
            target, source, downsampling_resolution=0.25, num_threads=1, registration_type="GICP"
        )
    )
    prepare_ms = median_ms(
        lambda: small_gicp.preprocess_points(
            source, downsampling_resolution=0.25, num_neighbors=10, num_threads=1
        )
    )
    print(f"align (both prepared): median {align_ms:.1f} ms")
    print(f"preprocess one cloud:  median {prepare_ms:.1f} ms")


if __name__ == "__main__":
    main()
