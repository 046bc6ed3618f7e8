"""Writing an FMU archive: a ZIP file with fixed timestamps and sorted
entries, so that the same inputs always give the same bytes."""
from __future__ import annotations

import io
import zipfile

from pysim.fmu.errors import BuildError

_EPOCH = (1980, 1, 1, 0, 0, 0)


def fmu_bytes(files: dict) -> bytes:
    """The FMU archive holding ``{path inside the FMU: bytes}``."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for path in sorted(files):
            if "\\" in path or path.startswith("/"):
                raise BuildError(f"bad path inside an FMU: {path!r}")
            info = zipfile.ZipInfo(path, date_time=_EPOCH)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            archive.writestr(info, files[path])
    return buffer.getvalue()
