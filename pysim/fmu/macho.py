"""Mach-O files: reading what a library exports, and merging single-architecture
libraries into one universal ("fat") file.

A universal file is a big-endian header (magic ``0xcafebabe``, number of
architectures), one ``fat_arch`` record per architecture (CPU type and
subtype, file offset, size, alignment as a power of two) and the
single-architecture files ("slices") at aligned offsets.  Apple's ``lipo``
writes the same thing; zig has no ``lipo``, so the builder writes it here.
"""
from __future__ import annotations

import struct

from pysim.fmu.errors import BuildError

FAT_MAGIC = 0xCAFEBABE
MH_MAGIC_64 = 0xFEEDFACF
CPU_TYPES = {0x01000007: "x86_64", 0x0100000C: "arm64"}
SLICE_ALIGNMENT = 14                 # 16 KiB, the arm64 page size

LC_SYMTAB = 0x2
LC_ID_DYLIB = 0xD
LC_LOAD_DYLIB = 0xC
LC_CODE_SIGNATURE = 0x1D
LC_BUILD_VERSION = 0x32
LC_VERSION_MIN_MACOSX = 0x24
LC_DYLD_INFO_ONLY = 0x80000022
LC_DYLD_EXPORTS_TRIE = 0x80000033
MH_DYLIB = 6


class MachOError(BuildError):
    """Not a (well-formed) Mach-O file."""


def is_universal(data: bytes) -> bool:
    return len(data) >= 8 and struct.unpack_from(">I", data)[0] == FAT_MAGIC


def slices(data: bytes) -> dict:
    """``{architecture: single-architecture bytes}`` of a universal or thin file."""
    if is_universal(data):
        (count,) = struct.unpack_from(">I", data, 4)
        out = {}
        for i in range(count):
            cputype, _sub, offset, size, _align = struct.unpack_from(">iiIII", data, 8 + 20 * i)
            if offset + size > len(data):
                raise MachOError(f"slice {i} runs past the end of the file")
            out[CPU_TYPES.get(cputype & 0xFFFFFFFF, hex(cputype))] = data[offset:offset + size]
        return out
    info = header(data)
    return {info["arch"]: data}


def header(data: bytes) -> dict:
    """CPU type, subtype and file type of a single-architecture 64-bit file."""
    if len(data) < 32 or struct.unpack_from("<I", data)[0] != MH_MAGIC_64:
        raise MachOError("not a 64-bit little-endian Mach-O file")
    _magic, cputype, subtype, filetype, ncmds, sizeofcmds, _flags = struct.unpack_from("<IiiIIII", data)
    return {"arch": CPU_TYPES.get(cputype & 0xFFFFFFFF, hex(cputype)), "cputype": cputype & 0xFFFFFFFF,
            "cpusubtype": subtype & 0x00FFFFFF, "filetype": filetype, "ncmds": ncmds, "sizeofcmds": sizeofcmds}


def write_universal(thin_files) -> bytes:
    """One universal file holding every single-architecture file given."""
    thin_files = list(thin_files)
    headers = [header(d) for d in thin_files]
    align = 1 << SLICE_ALIGNMENT
    offset = 8 + 20 * len(thin_files)
    records, layout = [], []
    for data, info in zip(thin_files, headers):
        offset = (offset + align - 1) // align * align
        records.append(struct.pack(">iiIII", info["cputype"], info["cpusubtype"], offset, len(data),
                                   SLICE_ALIGNMENT))
        layout.append((offset, data))
        offset += len(data)
    out = bytearray(offset)
    out[:8] = struct.pack(">II", FAT_MAGIC, len(thin_files))
    out[8:8 + 20 * len(records)] = b"".join(records)
    for start, data in layout:
        out[start:start + len(data)] = data
    return bytes(out)


def _load_commands(data: bytes):
    info = header(data)
    offset = 32
    for _ in range(info["ncmds"]):
        cmd, size = struct.unpack_from("<II", data, offset)
        if size < 8 or offset + size > len(data):
            raise MachOError("malformed load command")
        yield cmd, offset, size
        offset += size


def _uleb128(data: bytes, offset: int):
    value = shift = 0
    while True:
        byte = data[offset]
        offset += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, offset


def _trie_names(data: bytes, start: int, size: int) -> set:
    """Terminal names of an export trie (the table dyld looks symbols up in)."""
    names, seen, stack = set(), set(), [(0, b"")]
    end = start + size
    while stack:
        node, prefix = stack.pop()
        if node in seen or not 0 <= node < size:
            raise MachOError("malformed export trie")
        seen.add(node)
        p = start + node
        terminal, p = _uleb128(data, p)
        if terminal:
            names.add(prefix.decode())
        p += terminal
        count = data[p]
        p += 1
        for _ in range(count):
            stop = data.index(b"\0", p, end)
            label = data[p:stop]
            child, p = _uleb128(data, stop + 1)
            stack.append((child, prefix + label))
    return names


def _symtab_exports(data: bytes, offset: int) -> set:
    symoff, nsyms, stroff, _strsize = struct.unpack_from("<IIII", data, offset + 8)
    names = set()
    for i in range(nsyms):
        strx, n_type, n_sect, _desc, _value = struct.unpack_from("<IBBHQ", data, symoff + 16 * i)
        # external, defined in a section, not private-external
        if n_type & 0x01 and (n_type & 0x0E) == 0x0E and not n_type & 0x10 and n_sect:
            stop = data.index(b"\0", stroff + strx)
            names.add(data[stroff + strx:stop].decode())
    return names


def describe(data: bytes) -> dict:
    """What a single-architecture library offers: exported names (from the
    export trie and from the symbol table, without the leading underscore),
    linked libraries, minimum macOS version and whether it is code-signed."""
    info = header(data)
    trie, symtab, dylibs = None, set(), []
    min_os, signed = None, False
    for cmd, offset, _size in _load_commands(data):
        if cmd == LC_DYLD_INFO_ONLY:
            export_off, export_size = struct.unpack_from("<II", data, offset + 40)
            trie = _trie_names(data, export_off, export_size)
        elif cmd == LC_DYLD_EXPORTS_TRIE:
            dataoff, datasize = struct.unpack_from("<II", data, offset + 8)
            trie = _trie_names(data, dataoff, datasize)
        elif cmd == LC_SYMTAB:
            symtab = _symtab_exports(data, offset)
        elif cmd == LC_LOAD_DYLIB:
            (name_offset,) = struct.unpack_from("<I", data, offset + 8)
            stop = data.index(b"\0", offset + name_offset)
            dylibs.append(data[offset + name_offset:stop].decode())
        elif cmd == LC_BUILD_VERSION:
            (version,) = struct.unpack_from("<I", data, offset + 12)
            min_os = f"{version >> 16}.{(version >> 8) & 0xFF}"
        elif cmd == LC_VERSION_MIN_MACOSX:
            (version,) = struct.unpack_from("<I", data, offset + 8)
            min_os = f"{version >> 16}.{(version >> 8) & 0xFF}"
        elif cmd == LC_CODE_SIGNATURE:
            signed = True

    def strip(names):
        return {n[1:] if n.startswith("_") else n for n in names}

    return {"arch": info["arch"], "dylib": info["filetype"] == MH_DYLIB,
            "exports_trie": strip(trie or set()), "exports_symtab": strip(symtab),
            "dylibs": dylibs, "min_macos": min_os, "code_signature": signed}
