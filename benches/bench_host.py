"""One line that says which machine a benchmark ran on: the CPU (model name, family and model, as
/proc/cpuinfo gives them), the CPUs this process may use, and the SIMD paths flexclear's core
takes on it (``flexclear._core.SIMD_PATHS``: "avx512", "avx2" or "baseline").

This project's machines have not all had the same CPU. Earlier sessions measured on CPUs with
AVX-512 (where the Newton residual takes eight beam elements to a register); the eighteenth
session (2026-11-30) ran on an AMD EPYC of family 25, model 1 (Zen 3), AVX2 only, where
`profile_newton crank-pin 0.1` read 1.6 to 3.8 us a step, against 1.08 in earlier quiet runs
(97afd9d). Benchmarks print this line so that figures are compared on like machines."""

from __future__ import annotations

import os
import platform


def cpu() -> str:
    """The CPU's model name, with its family and model where /proc/cpuinfo gives them."""
    fields = {}
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if not line.strip():
                    break  # the first processor's block is enough
                key, _, value = line.partition(":")
                fields.setdefault(key.strip(), value.strip())
    except OSError:
        pass
    name = fields.get("model name") or platform.processor() or platform.machine() or "unknown CPU"
    if "cpu family" in fields and "model" in fields:
        name += f" (family {fields['cpu family']}, model {fields['model']})"
    return name


def describe() -> str:
    """`CPU: <cpu()>, <n> CPUs; flexclear SIMD paths: <paths>` (paths `?` without flexclear)."""
    try:
        n = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        n = os.cpu_count() or 0
    try:
        from flexclear import _core

        simd = _core.SIMD_PATHS
    except ImportError:
        simd = "?"
    return f"CPU: {cpu()}, {n} CPUs; flexclear SIMD paths: {simd}"


if __name__ == "__main__":
    print(describe())
