"""``tether kernel --certified --coarse H`` (big maps: the field searched on a coarse mesh,
read on the fine one and repaired in patches) and ``certified_kernel(coarse_h=...)``: the
answer a user reads, and one-line errors for a bad coarse spacing."""

from __future__ import annotations

import json

import pytest

from tether import Environment
from tether.cli import main
from tether.errors import InvalidParameterError
from tether.game.certified import certified_kernel

ROOM = {"name": "room65", "boundary": [[0, 0], [6, 0], [6, 5], [0, 5]]}
GAME = ["--lss", "1", "--vt", "0.3", "--vo", "1"]


@pytest.mark.parametrize("extra, message", [
    (["--coarse", "1"], "--coarse applies to --certified only"),
    (["--certified", "--h", "0.5", "--coarse", "0.25"], "coarse spacing must be a finite "
                                                         "number > h = 0.5"),
])
def test_bad_coarse_is_a_one_line_error(capsys, tmp_path, extra, message):
    room = tmp_path / "room.json"
    room.write_text(json.dumps(ROOM))
    assert main(["kernel", str(room), *GAME, *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_coarse_and_start_exclude_each_other():
    env = Environment(ROOM["boundary"])
    with pytest.raises(InvalidParameterError, match="exclude each other"):
        certified_kernel(env, 1.0, 0.3, 1.0, h=0.5, coarse_h=1.0, start=object())


@pytest.mark.slow
def test_certified_coarse_json(capsys, tmp_path):
    """The room certified from its field at h = 1 read at h = 0.5: the search's record
    starts with the coarse stage, and a state in the room's middle is safe."""
    room = tmp_path / "room.json"
    room.write_text(json.dumps(ROOM))
    assert main(["kernel", str(room), *GAME, "--certified", "--h", "0.5", "--coarse", "1",
                 "--orientations", "36", "--at", "3", "2.5", "0", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["certified"] is True and out["mesh"]["vertices"] == 208
    assert out["search"][0]["coarse"]["h"] == pytest.approx(1.0 * 2 ** -3)  # normalized frame
    assert out["at"]["certified"] == "safe"
