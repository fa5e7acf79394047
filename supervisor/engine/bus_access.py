"""A run's access to its bus, the supervisor's side: fresh credentials for every process, the router's
authentication, TLS and access-control settings (comms.access, comms.tls), and where each child finds its credential.

Every credential file is written 0600 in a private temporary directory that goes with the run; a child is handed
the path in its environment (comms.access.ENV), not on its command line. Vehicles started by hand (--remote) get
theirs in --credentials-dir, for the user to copy to their hosts. A supervisor that joins another router (--connect)
has nothing to hand out: that router's own settings (the site's Zenoh config) decide who may do what there.
"""

from __future__ import annotations

import contextlib
import ipaddress
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from comms.access import (
    ENV,
    Credential,
    access_control,
    dictionary,
    make_credentials,
    pem_base64,
    vehicle_name,
    write_private,
)
from comms.bus import Extras
from comms.tls import router_tls
from supervisor.config.scenario_schema import Scenario
from supervisor.engine.launch import BusOptions


@dataclass(frozen=True, slots=True)
class RunAccess:
    """The supervisor session's extras and each spawned child's credential file, by process name."""

    router: Extras
    files: Mapping[str, Path] = field(default_factory=dict)

    def env_of(self, name: str) -> dict[str, str]:
        """The environment entries that hand a child its credential."""
        path = self.files.get(name)
        return {ENV: str(path)} if path is not None else {}


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
    with tempfile.TemporaryDirectory(prefix="cpf-access-") as tmp:
        private = Path(tmp)  # mkdtemp: 0700
        credentials = make_credentials(sc.vehicle_ids)
        entries: dict[str, object] = {}
        if is_tls(endpoint):
            tls = router_tls([endpoint_host(endpoint)])
            credentials = {name: c.with_ca(tls.ca) for name, c in credentials.items()}
            entries["transport/link/tls/listen_certificate_base64"] = pem_base64(tls.certificate)
            entries["transport/link/tls/listen_private_key_base64"] = pem_base64(tls.key)
        users = private / "users"
        write_private(users, dictionary(credentials.values()))
        entries["transport/auth/usrpwd/dictionary_file"] = str(users)
        entries["access_control"] = access_control(credentials)
        files = {name: _write(private, c) for name, c in credentials.items()}
        if bus.credentials_dir is not None:
            hand_out(bus.credentials_dir, [credentials[vehicle_name(v)] for v in bus.remote])
        yield RunAccess(Extras(bus.zenoh_config, entries, credentials=True), files)


def hand_out(directory: Path, credentials: list[Credential]) -> list[Path]:
    """The credential files of vehicles started by hand, <dir>/vehicle-<id>.json, 0600 in a 0700 directory."""
    directory.mkdir(mode=0o700, parents=True, exist_ok=True)
    return [_write(directory, credential) for credential in credentials]


def _write(directory: Path, credential: Credential) -> Path:
    path = directory / f"{credential.name.replace(' ', '-')}.json"
    write_private(path, credential.to_json())
    return path
