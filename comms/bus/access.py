"""Who may do what on a run's bus: per-run credentials and the access-control rules the supervisor's router enforces.

Both are Zenoh's own mechanisms. Authentication: `transport.auth.usrpwd` (the router holds a dictionary file of
user:password lines, every client names its user and password; a session without them, or with wrong ones, is not
admitted at all). Authorisation: `access_control` with `default_permission: deny` and one policy per process, its
subject being its user name: a vehicle may publish only its own state and hold only its own liveliness token and hello
queryable; the broker publishes the channel's keys; nobody but the supervisor (the router's own session, which the
rules do not restrict) publishes on the clock or run keys. Every run makes fresh random users and passwords, one per
process; a child finds its credential in a 0600 file named by the environment variable CPF_CREDENTIALS (never on its
command line, which every user of the machine can read), a vehicle started by hand in the file given to --credentials.
"""

from __future__ import annotations

import base64
import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from comms.records.messages import (
    COMMS_ALIVE,
    COMMS_DONE_KEY,
    COMMS_EVENTS_KEY,
    COMMS_STATS_KEY,
    COMMS_STEP_KEY,
    FLUSH_KEY,
    ROOT,
    STOP_KEY,
    SUPERVISOR_ALIVE,
    TICK_KEY,
    hello_key,
    rx_key,
    state_key,
    vehicle_alive_key,
    vehicle_done_key,
)

ENV = "CPF_CREDENTIALS"  # names the credential file of a child the supervisor starts
COMMS = "comms broker"  # the process names the supervisor uses (supervisor.engine.supervisor)
FORMAT = "cpf-credentials/1"


def vehicle_name(vid: int) -> str:
    return f"vehicle {vid}"


@dataclass(frozen=True, slots=True)
class Credential:
    """One process's identity on one run's bus. ca: the run's CA certificate (PEM) when the bus is TLS."""

    name: str  # "comms broker", "vehicle 2"
    user: str
    password: str
    ca: str | None = None

    def to_json(self) -> str:
        data = {"format": FORMAT, "name": self.name, "user": self.user, "password": self.password, "ca": self.ca}
        return json.dumps(data, indent=2) + "\n"

    @classmethod
    def from_json(cls, text: str) -> Credential:
        """ValueError (saying what is wrong) for anything but a credential file cpf wrote."""
        try:
            data = json.loads(text)
        except ValueError:
            raise ValueError("not JSON: not a credential file cpf run wrote") from None
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ValueError(f"no 'format': {FORMAT!r}: not a credential file cpf run wrote")
        name, user, password, ca = (data.get(key) for key in ("name", "user", "password", "ca"))
        texts = (name, user, password)
        if not all(isinstance(value, str) and value for value in texts) or not isinstance(ca, str | None):
            raise ValueError("name, user and password must be non-empty strings, ca a PEM string or null")
        return cls(str(name), str(user), str(password), ca)

    def with_ca(self, ca: str | None) -> Credential:
        return Credential(self.name, self.user, self.password, ca)


def make_credentials(vehicle_ids: Iterable[int]) -> dict[str, Credential]:
    """Fresh random credentials for the broker and every vehicle of a run, by process name. The user name says whose
    it is (for a human reading the router's log), its random tail makes it unguessable like the password."""
    import secrets  # here, the supervisor's: its hashlib maps libcrypto (3.4 MB) into every process that reads one

    names = [COMMS, *(vehicle_name(v) for v in vehicle_ids)]
    return {name: Credential(name, f"{name.replace(' ', '-')}-{secrets.token_hex(8)}", secrets.token_urlsafe(24))
            for name in names}  # fmt: skip


def dictionary(credentials: Iterable[Credential]) -> str:
    """The router's usrpwd dictionary: one user:password line per process (token_urlsafe/hex hold no ':')."""
    return "".join(f"{c.user}:{c.password}\n" for c in credentials)


def write_private(path: Path, text: str) -> None:
    """A file only its owner can read, created so (never world-readable, not even for a moment)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as file:
        file.write(text)
    os.chmod(path, 0o600)  # an existing file keeps its mode through O_CREAT


def read_credential(path: Path) -> Credential:
    """ValueError '<path>: <problem>' for a file that is missing or not a credential."""
    try:
        return Credential.from_json(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ValueError(f"{path}: cannot read: {exc.strerror}") from None
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def credential_from_env() -> Credential | None:
    """The credential the supervisor handed this child (CPF_CREDENTIALS), or None if it handed none."""
    path = os.environ.get(ENV)
    return read_credential(Path(path)) if path else None


def client_config(credential: Credential) -> dict[str, Any]:
    """Zenoh config entries (key -> value) for a client that authenticates with credential."""
    entries: dict[str, Any] = {
        "transport/auth/usrpwd/user": credential.user,
        "transport/auth/usrpwd/password": credential.password,
    }
    if credential.ca is not None:
        entries["transport/link/tls/root_ca_certificate_base64"] = pem_base64(credential.ca)
        # Trust is pinned to the run's own CA, whose key never leaves the supervisor and which signs nothing but the
        # router's certificate: the name a remote host reaches it by (an address, an alias) need not be in it.
        entries["transport/link/tls/verify_name_on_connect"] = False
    return entries


def pem_base64(pem: str) -> str:
    """How Zenoh takes a PEM text inline (its *_base64 TLS settings): no file to write, none left behind."""
    return base64.b64encode(pem.encode()).decode()


# --- access control -------------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Right:
    """Zenoh messages allowed on key expressions in one direction: ingress (from the process to the router) or
    egress (from the router to the process)."""

    flow: str
    messages: tuple[str, ...]
    keys: tuple[str, ...]


def _publishes(keys: tuple[str, ...], subscribed: tuple[str, ...]) -> list[Right]:
    """Publishing on keys: the puts, and being told of the subscriptions there (subscribed: the key expressions the
    readers subscribe to, wildcards included). A Zenoh client sends only what someone subscribed to: without those
    declarations its publisher drops its messages, or not, depending on timing."""
    return [Right("ingress", ("put",), keys), Right("egress", ("declare_subscriber",), subscribed)]


def _listens(keys: tuple[str, ...]) -> list[Right]:
    """Subscribing to keys: declaring the subscriber, and being sent what is put there."""
    return [Right("ingress", ("declare_subscriber",), keys), Right("egress", ("put", "delete"), keys)]


def _process(alive: str) -> list[Right]:
    """What every child does: its own liveliness token and hello queryable (answering the supervisor's question),
    watching the supervisor's token, the stop message, and asking the supervisor to flush."""
    hello = hello_key(alive)
    return [
        Right("ingress", ("liveliness_token",), (alive,)),
        Right("ingress", ("declare_queryable", "reply"), (hello,)),
        Right("egress", ("query",), (hello,)),
        Right("ingress", ("query",), (FLUSH_KEY,)),  # its last messages are in before it closes (comms.bus.bus.flush)
        Right("egress", ("declare_queryable", "reply"), (FLUSH_KEY,)),
        Right("ingress", ("declare_liveliness_subscriber", "liveliness_query"), (SUPERVISOR_ALIVE,)),
        Right("egress", ("liveliness_token",), (SUPERVISOR_ALIVE,)),
        *_listens((STOP_KEY,)),
    ]


def vehicle_rights(vid: int) -> list[Right]:
    """A vehicle publishes its step messages and its end-of-run report; it reads the fleet's batches and its own
    realtime deliveries."""
    return [
        *_publishes((state_key(vid), vehicle_done_key(vid)), (state_key_pattern(), done_key_pattern())),
        *_listens((COMMS_STEP_KEY, rx_key(vid))),
        *_process(vehicle_alive_key(vid)),
    ]


def broker_rights() -> list[Right]:
    """The broker publishes the channel's keys (batches, events, stats, done, realtime deliveries); it reads the
    ticks and every vehicle's step messages."""
    channel = (COMMS_STEP_KEY, COMMS_EVENTS_KEY, COMMS_STATS_KEY, COMMS_DONE_KEY, rx_key_pattern())
    return [
        *_publishes(channel, channel),
        *_listens((TICK_KEY, state_key_pattern())),
        *_process(COMMS_ALIVE),
    ]


def state_key_pattern() -> str:
    return f"{ROOT}/vehicle/*/state"


def done_key_pattern() -> str:
    return f"{ROOT}/vehicle/*/done"


def rx_key_pattern() -> str:
    return f"{ROOT}/vehicle/*/rx"


def rights_of(name: str) -> list[Right]:
    if name == COMMS:
        return broker_rights()
    return vehicle_rights(int(name.removeprefix("vehicle ")))


def access_control(credentials: Mapping[str, Credential]) -> dict[str, Any]:
    """The router's access_control block: everything denied but each process's rights, by its user name. A
    session with no user (or another's) is refused before any rule applies: authentication comes first."""
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    for index, (name, credential) in enumerate(credentials.items()):
        ids = []
        for number, right in enumerate(rights_of(name)):
            rule_id = f"p{index}r{number}"
            ids.append(rule_id)
            rules.append({"id": rule_id, "messages": list(right.messages), "flows": [right.flow],
                          "permission": "allow", "key_exprs": list(right.keys)})  # fmt: skip
        subjects.append({"id": f"p{index}", "usernames": [credential.user]})
        policies.append({"id": f"policy{index}", "rules": ids, "subjects": [f"p{index}"]})
    return {"enabled": True, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies}
