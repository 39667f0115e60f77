"""The registry of bats: SQLite (one file, the default) or PostgreSQL (a league's server).

A bat is registered once under its serial number with its profile (stations), meta.json,
species, calibrated model parameters (``BatReference.to_dict()``), the baseline FRF file itself
(copied in, keyed by its SHA-256 and checked on every read) and the baseline's fitted modes.
Every later inspection is stored with its verdict, the re-test file and the time, and every
stored thing gets a signed record in the custody chain.

The package, one job a module: ``common`` (where the registry is, hashes, time stamps),
``schema`` (the tables, SQLAlchemy Core), ``lock`` (write transactions and their lock),
``migration`` and ``migrations/`` (Alembic), ``engine`` (opening a file or a server),
``health`` (the database's own storage check, run before any write),
``chain`` (appending and reading custody records), ``records`` (bats, files, inspections),
``calibrations`` (bat models' measured nulls), ``calibration_files`` (a calibration as a
signed file; the ones batlab ships), ``keys`` (a key rotated or revoked), ``witness`` (heads
as statements, witnessed, checked), ``verify`` (``registry check``) and ``copy``
(``registry copy``). Layout, locking and
migrations: docs/registry.md.
"""

from batlab.registry.calibration_files import (
    export_calibration,
    import_calibration,
    shipped_calibration,
)
from batlab.registry.calibrations import (
    StoredCalibration,
    add_calibration,
    get_calibration,
    latest_calibration,
    list_calibrations,
)
from batlab.registry.chain import (
    GENESIS_SHA256,
    CustodyRecord,
    chain_head,
    custody_record,
    custody_rows,
    head,
    lab_key,
    record_hash,
)
from batlab.registry.common import (
    BUSY_TIMEOUT_S,
    default_db_path,
    is_url,
    now_utc,
    sha256_bytes,
    shown,
)
from batlab.registry.copy import CopyResult, copy_registry
from batlab.registry.engine import connect, open_registry
from batlab.registry.keys import KeyChange, ended_keys, revoke_key, rotate_key
from batlab.registry.lock import transaction
from batlab.registry.migration import SCHEMA_VERSION, migrate, schema_version
from batlab.registry.records import (
    AlreadyStored,
    BatRecord,
    BatSummary,
    Inspection,
    add_bat,
    add_inspection,
    all_inspections,
    baseline_file,
    bat_as_registered,
    decode_modes,
    encode_modes,
    get_bat,
    get_inspection,
    has_bat,
    has_file,
    history,
    inspection_by_record,
    list_bats,
    set_report_path,
    store_file,
    stored_file,
)
from batlab.registry.verify import CheckResult, check
from batlab.registry.witness import head_statement, read_witnessed, witness_head

__all__ = [
    "AlreadyStored", "BUSY_TIMEOUT_S", "GENESIS_SHA256", "SCHEMA_VERSION", "BatRecord",
    "BatSummary",
    "CheckResult", "CopyResult", "CustodyRecord", "Inspection", "StoredCalibration", "add_bat",
    "add_calibration", "add_inspection", "get_calibration", "latest_calibration",
    "list_calibrations",
    "all_inspections", "baseline_file", "bat_as_registered", "chain_head", "check", "connect",
    "copy_registry", "custody_record", "custody_rows", "decode_modes", "default_db_path",
    "encode_modes", "get_bat", "get_inspection", "has_bat", "has_file", "head", "history",
    "inspection_by_record", "is_url", "list_bats", "migrate", "now_utc", "open_registry",
    "record_hash", "schema_version", "set_report_path", "sha256_bytes", "shown", "store_file",
    "stored_file", "transaction", "KeyChange", "ended_keys", "export_calibration",
    "head_statement", "import_calibration", "lab_key", "read_witnessed", "revoke_key",
    "rotate_key", "shipped_calibration", "witness_head",
]
