"""The log's Foxglove view of a run: channels with Foxglove's well-known schemas (3-D scene, frames, trails) built
from the run's cpf records by a pure builder (scene.FleetScene), which the recorder feeds and a reader of an older
log can feed too."""
