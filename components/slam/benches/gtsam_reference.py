"""The reference for `speleo g2o FILE.g2o`: GTSAM's Levenberg-Marquardt
(PyPI gtsam 4.3, default parameters, first pose held by a tight prior) on
the same file, timed the same way (median of repeated runs), with its chi2
(twice GTSAM's error).

    python3 -m venv venv && venv/bin/pip install numpy gtsam
    venv/bin/python gtsam_reference.py ../shared/data/posegraph/parking-garage.g2o 3
    venv/bin/python gtsam_reference.py ../shared/data/posegraph/intel.g2o 2

GTSAM starts from the file's poses; `speleo g2o` starts from its chordal
initialisation and counts that time in its total.
"""

import statistics
import sys
import time

import gtsam
import numpy as np


def solve(path, is3d):
    graph, initial = gtsam.readG2o(path, is3d)
    if is3d:
        prior = gtsam.noiseModel.Diagonal.Variances(np.array([1e-6] * 3 + [1e-4] * 3))
        graph.add(gtsam.PriorFactorPose3(0, initial.atPose3(0), prior))
    else:
        prior = gtsam.noiseModel.Diagonal.Variances(np.array([1e-6, 1e-6, 1e-8]))
        graph.add(gtsam.PriorFactorPose2(0, initial.atPose2(0), prior))
    t = time.perf_counter()
    optimizer = gtsam.LevenbergMarquardtOptimizer(graph, initial, gtsam.LevenbergMarquardtParams())
    result = optimizer.optimize()
    return time.perf_counter() - t, 2 * graph.error(result), optimizer.iterations()


def main():
    path, is3d = sys.argv[1], sys.argv[2] == "3"
    runs = [solve(path, is3d) for _ in range(7)]
    seconds = statistics.median(r[0] for r in runs)
    _, chi2, iterations = runs[0]
    print(f"{path}: chi2 {chi2:.6f}, {iterations} iterations, median {seconds:.3f} s")


if __name__ == "__main__":
    main()
