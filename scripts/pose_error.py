#!/usr/bin/env python3
"""Pose error of a CLI result against a scene's truth.json (no dependencies).

    scripts/pose_error.py TRUTH.json RESULT.json

For every reported instance, the truth placement (each truth transform, composed
with each of the template's symmetries) nearest to its position is taken, and
two errors are printed: the angle of the rotation between the reported pose and
that placement, in degrees, and the distance between where the two put c_T, as
a share of the template's radius. The last line gives the worst of each; the
exit status is 0 when both are within the issue's bounds (2 degrees, 2%).
"""
import json, math, sys

def apply(T, p):
    return [sum(T[r][c] * p[c] for c in range(3)) + T[r][3] for r in range(3)]

def compose(A, B):
    return [[sum(A[r][k] * B[k][c] for k in range(4)) for c in range(4)] for r in range(4)]

def rotation_angle(A, B):
    # angle of A_rot * B_rot^T, both scaled to unit columns (truth may carry a scale)
    def unit(T):
        cols = [[T[r][c] for r in range(3)] for c in range(3)]
        cols = [[x / math.sqrt(sum(y * y for y in col)) for x in col] for col in cols]
        return [[cols[c][r] for c in range(3)] for r in range(3)]
    a, b = unit(A), unit(B)
    trace = sum(a[r][k] * b[r][k] for r in range(3) for k in range(3))
    return math.degrees(math.acos(max(-1.0, min(1.0, (trace - 1) / 2))))

def main():
    truth = json.load(open(sys.argv[1]))
    result = json.load(open(sys.argv[2]))
    c = result["template"]["center"]
    radius = float(truth.get("template_radius", 1.0))
    syms = truth.get("template_symmetries") or [None]
    placements = [t["transform"] if S is None else compose(t["transform"], S)
                  for t in truth["instances"] for S in syms]
    worst_angle = worst_shift = 0.0
    for i, instance in enumerate(result["instances"]):
        pose = instance.get("pose") or instance.get("transform")
        p = apply(pose, c)
        best = min(placements, key=lambda T: (math.dist(p, apply(T, c)), rotation_angle(pose, T)))
        # among placements that put c_T at the same spot (symmetries), the closest rotation
        same = [T for T in placements if math.dist(apply(T, c), apply(best, c)) < 1e-6 * max(1.0, radius)]
        angle = min(rotation_angle(pose, T) for T in same)
        shift = math.dist(p, apply(best, c)) / radius
        worst_angle, worst_shift = max(worst_angle, angle), max(worst_shift, shift)
        print(f"#{i + 1:<3} rotation {angle:7.3f} deg  c_T {100 * shift:6.2f}% r")
    print(f"worst: rotation {worst_angle:.3f} deg, c_T {100 * worst_shift:.2f}% r")
    sys.exit(0 if worst_angle <= 2.0 and worst_shift <= 0.02 else 1)

main()
