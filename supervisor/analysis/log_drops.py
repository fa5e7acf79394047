"""What the bus's readers dropped, read back from a run's log: the end-of-run reports of the supervisor
(cpf/run/done), the broker (cpf/comms/done) and each vehicle (cpf/vehicle/<id>/done), as one table
(comms.records.reports.bus_drops: the one `cpf run` prints and writes to --metrics)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from comms.records.messages import COMMS_DONE_KEY, RUN_DONE_KEY, vehicle_of_key
from comms.records.reports import BusDrops, CommsDone, SupervisorDone, VehicleDone, bus_drops, bus_readers
from supervisor.record.meta import RunMeta

DONE_TOPICS = frozenset({COMMS_DONE_KEY, RUN_DONE_KEY})  # and each vehicle's done key


def is_done_topic(topic: str) -> bool:
    owned = vehicle_of_key(topic)
    return topic in DONE_TOPICS if owned is None else owned[1] == "done"


@dataclass
class DoneReports:
    """The end-of-run reports of a log (the broker's latest: a restarted broker's)."""

    supervisor: SupervisorDone | None = None
    broker: CommsDone | None = None
    vehicles: dict[int, VehicleDone] = field(default_factory=dict)

    def add(self, topic: str, message: dict[str, Any]) -> None:
        """One report (ValueError naming the field for one that does not read)."""
        owned = vehicle_of_key(topic)
        if owned is not None:
            self.vehicles[owned[0]] = VehicleDone.from_message(message, owned[0])
        elif topic == COMMS_DONE_KEY:
            self.broker = CommsDone.from_message(message)
        elif topic == RUN_DONE_KEY:
            self.supervisor = SupervisorDone.from_message(message)

    def drops(self, meta: RunMeta | None) -> BusDrops:
        """The readers' table; a Zenoh run's reader that sent no report, None (a log of an earlier version, without
        the supervisor's report: the others' alone)."""
        zenoh = meta is not None and meta.engine == "zenoh" and self.supervisor is not None
        expected = bus_readers(meta.vehicles) if zenoh and meta is not None else []
        return bus_drops(self.supervisor, self.broker, self.vehicles, expected)
