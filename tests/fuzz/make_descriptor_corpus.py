#!/usr/bin/python3
"""Writes the seed corpus of the plugin descriptor fuzzer (tests/fuzz/descriptor-corpus/*.bin) in the byte format
that EntryBuilder in descriptor_check.hpp decodes: plugins the reader must accept (the shapes of the built-in ones,
three in one entry, dimension 64), and, named refused-*, entries it must refuse (test_fuzz_regressions checks which).
Run from the repository root: /usr/bin/python3 tests/fuzz/make_descriptor_corpus.py"""
import os
import struct

FOLDER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "descriptor-corpus")
NONE = b"\xff"  # a NULL string
REAL, INTEGER, BOOL, STRING = 1, 2, 3, 4  # gb_param_type
SYSTEM, FORCING, EXTRACTOR = 1, 2, 3  # gb_plugin_kind


def count(n, limit):
    """A count as ByteReader::count reads it: one byte up to `limit`, else 0xf0 and 32 bits."""
    return bytes([n]) if n <= limit else b"\xf0" + struct.pack("<I", n)


def text(s):
    """An ended string of fewer than 64 characters."""
    b = s.encode()
    assert len(b) < 64
    return bytes([len(b)]) + b


UNENDED = lambda c: b"\x80" + c * 65  # a name of 65 bytes without its end


def param(name, kind, default, lo, hi, default_string=None, choices=None, unit="", doc="a parameter"):
    out = text(name) + bytes([kind + 1]) + struct.pack("<ddd", default, lo, hi)  # type = byte % 6 - 1
    for s in (default_string, choices, unit, doc):
        out += NONE if s is None else text(s)
    return out


def descriptor(kind, name, flags, tables, params=(), param_count=None, raw_name=None):
    """flags: 1 create, 2 destroy, 4 core_version, 8 system, 16 forcing, 32 extractor, 64 no params array."""
    out = bytes([kind + 1]) + (raw_name or text(name)) + text("1.0.0") + text("a plugin") + bytes([1, flags])
    out += tables + count(len(params) if param_count is None else param_count, 6) + b"".join(params)
    return out


def system(dimension, capabilities, flags, domain=None, names=None, units=None, raw=b""):
    """flags: 1 rhs, 2 jacobian, 4 domain_min, 8 domain_max, 16 state_names, 32 state_units."""
    out = count(dimension, 8) + bytes([capabilities, flags])
    if flags & 4:
        out += struct.pack("<%dd" % dimension, *domain[0])
    if flags & 8:
        out += struct.pack("<%dd" % dimension, *domain[1])
    if flags & 16:
        out += raw or b"".join(text(n) for n in names)
    if flags & 32:
        out += b"".join(text(u) for u in units)
    return out


def forcing(flags, min_terms, max_terms):
    """flags: 1 evaluate, 2 combine."""
    return bytes([flags]) + count(min_terms, 4) + count(max_terms, 4)


def extractor(fields):
    return bytes([1 | 2]) + count(len(fields), 80) + b"".join(text(f) for f in fields)


def entry(abi_minor, descriptors):
    return bytes([1, abi_minor]) + count(len(descriptors), 3) + b"".join(descriptors) + b"\x00"


duffing = descriptor(SYSTEM, "duffing", 1 | 2 | 8,
                     system(2, 4, 1 | 2 | 4 | 8 | 16 | 32, ([-3, -3], [3, 3]), ["x", "y"], ["m", "m/s"]),
                     [param("alpha", REAL, 1, -1e9, 1e9), param("beta", REAL, 1, -1e9, 1e9),
                      param("delta", REAL, 0, 0, 1e9)])
cosine = descriptor(FORCING, "cosine", 1 | 2 | 16, forcing(1, 0, 0),
                    [param("amplitude", REAL, 0.1, -1e9, 1e9), param("omega", REAL, 1, 0, 1e9)])
ramp = descriptor(FORCING, "ramp", 1 | 2 | 16, forcing(3, 1, 1), [param("t_ramp", REAL, 1, 0, 1e9)])
hyperbolic = descriptor(EXTRACTOR, "hyperbolic", 1 | 2 | 32, extractor(["lambda2", "xi2"]),
                        [param("method", STRING, 0, 0, 0, "curves", "curves|grid"),
                         param("count", INTEGER, 10, 1, 1000), param("closed", BOOL, 0, 0, 1)])
wide = descriptor(SYSTEM, "wide", 1 | 2 | 8, system(64, 0, 1 | 16, names=["x%d" % k for k in range(64)]),
                  [param("k%d" % k, REAL, 0, -1, 1) for k in range(6)])

seeds = {
    "system-duffing.bin": entry(2, [duffing]),
    "forcing-cosine.bin": entry(1, [cosine]),
    "composite-ramp.bin": entry(1, [ramp]),
    "extractor-hyperbolic.bin": entry(3, [hyperbolic]),
    "three-plugins.bin": entry(4, [duffing, cosine, hyperbolic]),
    "dimension-64.bin": entry(2, [wide]),
    "refused-dimension-4294967295.bin": entry(2, [descriptor(SYSTEM, "huge", 1 | 2 | 8, system(0xFFFFFFFF, 0, 1))]),
    "refused-4294967295-params.bin":
        entry(2, [descriptor(FORCING, "many", 1 | 2 | 16, forcing(1, 0, 0), param_count=0xFFFFFFFF)]),
    "refused-unended-name.bin":
        entry(2, [descriptor(FORCING, "", 1 | 2 | 16, forcing(1, 0, 0), raw_name=UNENDED(b"a"))]),
    "refused-unended-state-name.bin":
        entry(2, [descriptor(SYSTEM, "s", 1 | 2 | 8, system(2, 0, 1 | 16, raw=UNENDED(b"b") + text("y")))]),
    "refused-80-fields.bin":
        entry(2, [descriptor(EXTRACTOR, "fields", 1 | 2 | 32, extractor(["f%d" % k for k in range(80)]))]),
    "refused-composite-without-combine.bin": entry(1, [descriptor(FORCING, "sum", 1 | 2 | 16, forcing(1, 1, 4))]),
    "refused-abi-2.bin": b"\x00" + entry(2, [duffing])[1:],
}
os.makedirs(FOLDER, exist_ok=True)
for name, data in seeds.items():
    with open(os.path.join(FOLDER, name), "wb") as f:
        f.write(data)
