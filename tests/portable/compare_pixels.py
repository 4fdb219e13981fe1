"""Compares two capi_selftest --pixels files value by value (tests/capi/CMakeLists.txt).

Usage: compare_pixels.py REFERENCE OTHER LABEL [TOLERANCE]

REFERENCE is the native Linux run's sky; OTHER another platform's or CPU's (Windows under wine64,
Linux under an emulated pre-AVX CPU). Values below 1e-6 (the dark ground) are compared absolutely
through the relative formula's floor; the largest relative difference must be <= TOLERANCE (1e-5:
the kernels differ only in rounding, FMA or not, which moves a pixel by ~1e-7).
"""
import sys


def main(argv):
    if len(argv) not in (4, 5):
        print(__doc__)
        return 2
    ref_path, other_path, label = argv[1], argv[2], argv[3]
    tol = float(argv[4]) if len(argv) == 5 else 1e-5
    try:
        a = [float(x) for x in open(ref_path)]
        b = [float(x) for x in open(other_path)]
    except OSError as e:
        print(f"FAIL: {e}")
        return 1
    if len(a) != len(b) or not a:
        print(f"FAIL: {len(a)} reference values, {len(b)} {label} values")
        return 1
    worst = max((abs(x - y) / max(abs(x), 1e-30) for x, y in zip(a, b) if abs(x) > 1e-6), default=0.0)
    print(f"sky pixels, {label} vs native Linux: {len(a)} values, largest relative difference {worst:.3g}")
    if not worst <= tol:
        print(f"FAIL: the {label} sky differs from the native Linux sky by more than {tol:g} relative")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
