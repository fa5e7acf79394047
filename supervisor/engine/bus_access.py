"""A run's access to its bus, the supervisor's side: fresh credentials for every process, the router's
authentication, TLS and access-control settings (comms.bus.access, comms.bus.tls), and where each child finds its
credential.

On Linux nothing is written to disk: the router's dictionary and each child's credential are memory files
(memfd), the child inherits its own by file descriptor and finds it at /proc/self/fd/N, named in its environment
(comms.bus.access.ENV), never on its command line; they vanish with the processes, however the run ends (a SIGKILLed
supervisor left a directory of credentials behind). Elsewhere they are 0600 files in a private temporary directory
that goes with the run. Vehicles started by hand (--remote) get
theirs in --credentials-dir, for the user to copy to their hosts. A supervisor that joins another router (--connect)
has nothing to hand out: that router's own settings (the site's Zenoh config) decide who may do what there.
"""

from __future__ import annotations

import contextlib
import ipaddress
import os
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from comms.bus.access import (
    ENV,
    Credential,
    access_control,
    dictionary,
    make_credentials,
    pem_base64,
    vehicle_name,
    write_private,
)
from comms.bus.bus import Extras
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.hosting import hosted_ids
from supervisor.engine.launch import BusOptions

ZENOH_MAX_SESSIONS = 1000  # Zenoh's default transport/unicast/max_sessions
SPARE_SESSIONS = 64  # beyond the fleet and the broker: live viewers, replay tools


@dataclass(frozen=True, slots=True)
class RunAccess:
    """The supervisor session's extras and each spawned child's credential file, by process name."""

    router: Extras
    files: Mapping[str, Path] = field(default_factory=dict)
    fds: Mapping[str, int] = field(default_factory=dict)  # memory files, inherited by the child at the same number

    def env_of(self, name: str) -> dict[str, str]:
        """The environment entries that hand a child its credential (a vehicle host: each of its vehicles')."""
        paths = [
            str(self.credential_path(member)) for member in _members(name) if member in self.fds or member in self.files
        ]
        return {ENV: os.pathsep.join(paths)} if paths else {}

    def credential_path(self, name: str) -> Path:
        """Where this process reads the credential of the child called name (tests, and the user's --credentials)."""
        return Path(f"/proc/self/fd/{self.fds[name]}") if name in self.fds else self.files[name]

    def fds_of(self, name: str) -> tuple[int, ...]:
        """The file descriptors a child inherits: its credential's memory file (a vehicle host: its vehicles')."""
        return tuple(self.fds[member] for member in _members(name) if member in self.fds)


def _members(name: str) -> list[str]:
    """The processes a child of that name stands for: a vehicle host's vehicles, else itself."""
    ids = hosted_ids(name)
    return [name] if ids is None else [vehicle_name(v) for v in ids]


def endpoint_host(endpoint: str) -> str:
    """The host of a Zenoh endpoint 'proto/host:port[?config][#metadata]' ('[::1]' -> '::1')."""
    address = endpoint.split("/", 1)[-1].split("#")[0].split("?")[0]
    return address.rsplit(":", 1)[0].strip("[]")


def is_loopback(endpoint: str) -> bool:
    host = endpoint_host(endpoint)
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False  # a host name other than localhost: reachable from elsewhere


def is_tls(endpoint: str) -> bool:
    return endpoint.startswith("tls/")


@contextlib.contextmanager
def run_access(sc: Scenario, bus: BusOptions, endpoint: str) -> Iterator[RunAccess]:
    """The run's credentials and router settings, for as long as the run lasts (then its private files go)."""
    if bus.connect:
        yield RunAccess(Extras(bus.zenoh_config))
        return
    credentials = make_credentials(sc.vehicle_ids)
    entries: dict[str, object] = {}
    if is_tls(endpoint):
        from comms.bus.tls import router_tls  # here: `cryptography` costs every other run ~17 ms of start-up

        tls = router_tls([endpoint_host(endpoint)])
        credentials = {name: c.with_ca(tls.ca) for name, c in credentials.items()}
        entries["transport/link/tls/listen_certificate_base64"] = pem_base64(tls.certificate)
        entries["transport/link/tls/listen_private_key_base64"] = pem_base64(tls.key)
    entries["access_control"] = access_control(credentials)
    entries.update(session_room(len(sc.vehicle_ids)))
    if bus.credentials_dir is not None:
        hand_out(bus.credentials_dir, [credentials[vehicle_name(v)] for v in bus.remote])
    with _private(credentials) as (users, files, fds):
        entries["transport/auth/usrpwd/dictionary_file"] = users
        yield RunAccess(Extras(bus.zenoh_config, entries, credentials=True), files, fds)


def session_room(vehicles: int) -> dict[str, object]:
    """The router's session limit, raised where the fleet needs more than Zenoh's default 1000 (every vehicle its own
    session, hosted or not, and the broker; SPARE_SESSIONS for live viewers and tools): the 1000th vehicle of a ring
    of 1000 was refused, and the run timed out waiting for it to come alive."""
    needed = vehicles + 1 + SPARE_SESSIONS
    return {"transport/unicast/max_sessions": needed} if needed > ZENOH_MAX_SESSIONS else {}


@contextlib.contextmanager
def _private(
    credentials: Mapping[str, Credential],
) -> Iterator[tuple[str, dict[str, Path], dict[str, int]]]:
    """(the router's dictionary path, credential files, credential memory files) for the run's lifetime."""
    text = dictionary(credentials.values())
    if hasattr(os, "memfd_create"):
        fds = {name: _memory(name, c.to_json()) for name, c in credentials.items()}
        users = _memory("users", text)
        try:
            yield f"/proc/self/fd/{users}", {}, fds
        finally:
            for fd in (users, *fds.values()):
                os.close(fd)
        return
    with tempfile.TemporaryDirectory(prefix="cpf-access-") as tmp:
        private = Path(tmp)  # mkdtemp: 0700
        write_private(private / "users", text)
        yield str(private / "users"), {name: _write(private, c) for name, c in credentials.items()}, {}


def _memory(name: str, text: str) -> int:
    """A memory file holding text (Linux): no path on disk, gone when its last descriptor closes."""
    fd = os.memfd_create(f"cpf-{name}", os.MFD_CLOEXEC)
    os.write(fd, text.encode())
    return fd


def hand_out(directory: Path, credentials: list[Credential]) -> list[Path]:
    """The credential files of vehicles started by hand, <dir>/vehicle-<id>.json, 0600 in a 0700 directory."""
    directory.mkdir(mode=0o700, parents=True, exist_ok=True)
    return [_write(directory, credential) for credential in credentials]


def _write(directory: Path, credential: Credential) -> Path:
    """Written whole under a temporary name, then renamed: whoever waits for the file never reads half of it."""
    path = directory / f"{credential.name.replace(' ', '-')}.json"
    partial = path.with_name(f".{path.name}.partial")
    write_private(partial, credential.to_json())
    os.replace(partial, path)
    return path
