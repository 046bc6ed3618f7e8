"""What a compiled FMU binary exports and needs, read from the file itself
(ELF for linux64, PE for win64, Mach-O for darwin64), so a build can be
verified without the target platform.
"""
from __future__ import annotations

import struct

from pysim.fmu import macho
from pysim.fmu.errors import BuildError

# Every function of the FMI 2.0 co-simulation interface (common + CS part).
FMI2_CS_FUNCTIONS = (
    "fmi2GetTypesPlatform", "fmi2GetVersion", "fmi2SetDebugLogging", "fmi2Instantiate",
    "fmi2FreeInstance", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset", "fmi2GetReal", "fmi2GetInteger",
    "fmi2GetBoolean", "fmi2GetString", "fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean",
    "fmi2SetString", "fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate", "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative", "fmi2SetRealInputDerivatives", "fmi2GetRealOutputDerivatives",
    "fmi2DoStep", "fmi2CancelStep", "fmi2GetStatus", "fmi2GetRealStatus", "fmi2GetIntegerStatus",
    "fmi2GetBooleanStatus", "fmi2GetStringStatus",
)

# Symbols the macOS linker defines in every dylib (the image header).
MACHO_LINKER_SYMBOLS = frozenset({"_mh_dylib_header", "__dso_handle"})


class BinaryError(BuildError):
    """A file that is not the kind of binary expected."""


def _cstring(data: bytes, offset: int) -> str:
    return data[offset:data.index(b"\0", offset)].decode("ascii", "replace")


# ------------------------------------------------------------------ ELF
def _elf_sections(data: bytes) -> list:
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise BinaryError("not a 64-bit little-endian ELF file")
    shoff, = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
    sections = []
    for i in range(shnum):
        (_name, sh_type, _flags, _addr, offset, size, link, _info, _align,
         entsize) = struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize)
        sections.append({"type": sh_type, "offset": offset, "size": size, "link": link, "entsize": entsize})
    return sections


def elf_info(data: bytes) -> dict:
    """Exported (default-visibility, defined) dynamic symbols, needed
    libraries' symbol versions (e.g. ``GLIBC_2.14``) of a shared object."""
    sections = _elf_sections(data)
    exports, versions = set(), set()
    for sec in sections:
        strtab = sections[sec["link"]]["offset"] if sec["type"] in (11, 0x6FFFFFFE) else None
        if sec["type"] == 11:                                   # SHT_DYNSYM
            for i in range(sec["size"] // 24):
                name, info, other, shndx, _value, _size = struct.unpack_from(
                    "<IBBHQQ", data, sec["offset"] + 24 * i)
                if name and shndx != 0 and (info >> 4) in (1, 2) and (other & 3) in (0, 3):
                    exports.add(_cstring(data, strtab + name))
        elif sec["type"] == 0x6FFFFFFE:                         # SHT_GNU_verneed
            p = sec["offset"]
            while True:
                _ver, count, _file, aux, nxt = struct.unpack_from("<HHIII", data, p)
                q = p + aux
                for _ in range(count):
                    _hash, _flags, _other, name, anext = struct.unpack_from("<IHHII", data, q)
                    versions.add(_cstring(data, strtab + name))
                    q += anext
                if not nxt:
                    break
                p += nxt
    return {"exports": exports, "versions": versions}


# ------------------------------------------------------------------- PE
def pe_info(data: bytes) -> dict:
    """Exported names, imported DLLs and machine of a PE32+ DLL."""
    if data[:2] != b"MZ":
        raise BinaryError("not a PE file")
    pe, = struct.unpack_from("<I", data, 0x3C)
    if data[pe:pe + 4] != b"PE\0\0":
        raise BinaryError("PE signature missing")
    machine, nsections = struct.unpack_from("<HH", data, pe + 4)
    opt_size, = struct.unpack_from("<H", data, pe + 20)
    opt = pe + 24
    if struct.unpack_from("<H", data, opt)[0] != 0x20B:
        raise BinaryError("not a PE32+ (64-bit) file")
    ndirs, = struct.unpack_from("<I", data, opt + 108)
    dirs = [struct.unpack_from("<II", data, opt + 112 + 8 * i) for i in range(min(ndirs, 16))]
    table = opt + opt_size
    sections = [struct.unpack_from("<IIII", data, table + 40 * i + 8) for i in range(nsections)]

    def offset(rva):
        for vsize, vaddr, rawsize, rawptr in sections:
            if vaddr <= rva < vaddr + max(vsize, rawsize):
                return rva - vaddr + rawptr
        raise BinaryError(f"RVA {rva:#x} is in no section")

    exports = set()
    if dirs and dirs[0][0]:
        e = offset(dirs[0][0])
        nnames, = struct.unpack_from("<I", data, e + 24)
        names_rva, = struct.unpack_from("<I", data, e + 32)
        for i in range(nnames):
            name_rva, = struct.unpack_from("<I", data, offset(names_rva) + 4 * i)
            exports.add(_cstring(data, offset(name_rva)))
    imports = []
    if len(dirs) > 1 and dirs[1][0]:
        p = offset(dirs[1][0])
        while True:
            entry = struct.unpack_from("<IIIII", data, p)
            if not any(entry):
                break
            imports.append(_cstring(data, offset(entry[3])))
            p += 20
    return {"exports": exports, "imports": imports, "machine": {0x8664: "x86_64"}.get(machine, hex(machine))}


# -------------------------------------------------------------- dispatch
def exports_by_architecture(data: bytes) -> dict:
    """``{architecture: exported names}`` of an ELF, PE or (universal) Mach-O
    library; names as C sees them (no leading underscore on macOS)."""
    if data[:4] == b"\x7fELF":
        return {"x86_64": elf_info(data)["exports"]}
    if data[:2] == b"MZ":
        info = pe_info(data)
        return {info["machine"]: info["exports"]}
    out = {}
    for arch, thin in macho.slices(data).items():
        names = macho.describe(thin)["exports_trie"]
        out[arch] = names - MACHO_LINKER_SYMBOLS
    return out


def check_exports(data: bytes, what: str) -> None:
    """Raises BinaryError unless every architecture in the file exports
    exactly the FMI 2.0 co-simulation functions."""
    expected = set(FMI2_CS_FUNCTIONS)
    for arch, names in exports_by_architecture(data).items():
        missing, extra = expected - names, names - expected
        if missing or extra:
            raise BinaryError(f"{what} ({arch}): missing exports {sorted(missing)}, "
                              f"unexpected exports {sorted(extra)}")
