#!/usr/bin/env python3
"""Where the TAA resolve's time goes, per line of resolve_block.

Every step of the resolve is inlined into one lambda, so `perf report` shows one symbol.
This script attributes each sample of a `perf record` (no -g needed) to the outermost
inlined frame that lies in a chosen source file (default src/taa/resolver.cpp), using the
binary's debug info (build with -g; addr2line -i), and prints the share of each line.

  cmake -S . -B build-prof -G Ninja -DCMAKE_BUILD_TYPE=Release \\
        -DCMAKE_CXX_FLAGS="-g -fno-omit-frame-pointer" -DAFTERIMAGE_BUILD_TESTS=OFF
  ninja -C build-prof afterimage
  perf record -F 4000 -o perf.data build-prof/afterimage bench --sizes 1920x1080 \\
        --filter taa.resolve.afterimage --repeats 10
  scripts/perf_lines.py perf.data build-prof/afterimage [--file resolver.cpp] [--detail LINE]

--detail resolver.cpp:113 breaks one line down by its innermost inlined frames.
"""
import argparse
import collections
import re
import subprocess


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("binary")
    ap.add_argument("--file", default="resolver.cpp")
    ap.add_argument("--symbol", default="TemporalResolver", help="substring of sampled symbols")
    ap.add_argument("--detail", action="append", default=[])
    a = ap.parse_args()

    out = subprocess.run(["perf", "script", "-i", a.data, "-F", "ip,sym,symoff,dso",
                          "--no-demangle"], capture_output=True, text=True).stdout
    per_sym = collections.Counter()
    per_site = collections.Counter()
    total = 0
    for line in out.splitlines():
        m = re.search(r"(\S+)\+0x([0-9a-f]+)\s+\((\S+)\)", line)
        if not line.strip():
            continue
        total += 1
        if not m:
            continue
        per_sym[m.group(1)] += 1
        per_site[(m.group(1), int(m.group(2), 16))] += 1
    addr = {}
    for l in subprocess.run(["nm", "--defined-only", a.binary], capture_output=True,
                            text=True).stdout.splitlines():
        p = l.split(None, 2)
        if len(p) == 3:
            addr[p[2]] = int(p[0], 16)
    samples = collections.Counter()
    for (sym, off), n in per_site.items():
        if a.symbol in sym and sym in addr:
            samples[addr[sym] + off] += n
    chains, cur = {}, None
    res = subprocess.run(["addr2line", "-i", "-a", "-e", a.binary] +
                         [hex(x) for x in samples], capture_output=True, text=True).stdout
    for l in res.splitlines():
        if l.startswith("0x"):
            cur = int(l, 16)
            chains[cur] = []
        else:
            chains[cur].append(l.split("/")[-1].split(" ")[0])
    lines = collections.Counter()
    detail = collections.defaultdict(collections.Counter)
    for x, n in samples.items():
        ch = chains.get(x, [])
        i = next((k for k, f in enumerate(ch) if a.file in f), None)
        key = ch[i] if i is not None else "other"
        lines[key] += n
        if i is not None:
            inner = [f for f in ch[:i] if "intrin" not in f and "x86_" not in f]
            detail[key][" < ".join(inner[:3]) or "(direct)"] += n
    print(f"{total} samples")
    for s, n in per_sym.most_common(15):
        print(f"{100 * n / total:6.2f}%  {s[:100]}")
    k = sum(lines.values())
    print(f"--- {k} samples in symbols matching '{a.symbol}', by line of {a.file}")
    for key, n in lines.most_common(40):
        print(f"{100 * n / k:6.2f}%  {key}")
    for d in a.detail:
        t = sum(detail[d].values())
        print(f"--- {d}: {t} samples")
        for key, n in detail[d].most_common(15):
            print(f"{100 * n / max(t, 1):6.2f}%  {key}")


if __name__ == "__main__":
    main()
