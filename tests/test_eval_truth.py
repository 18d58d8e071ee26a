"""The annotated-people reader: the PETS truth as the footage's README describes it, and clear
errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from gazed.eval.truth import COLUMNS, TruthFileError, read_truth

PETS_TRUTH = SHARED_DATA / "footage" / "pets09-s2l1" / "truth_frames_0000-0399.csv"
HEADER = ",".join(COLUMNS)


def write(tmp_path: Path, *lines: str) -> Path:
    path = tmp_path / "truth.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_people_by_id_in_frame_order(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        HEADER,
        "1,0.1429,7,10,20,5,12,10,26,1.5,-2.0",
        "0,0.0,7,9,20,5,12,9,26,1.4,-2.0",
        "0,0.0,3,100,50,8,20,100,60,4.0,5.0",
    )
    people = read_truth(path)
    assert sorted(people) == [3, 7]
    walker = people[7]
    assert walker.frame.tolist() == [0, 1]
    assert np.allclose(walker.ground_m, [[1.4, -2.0], [1.5, -2.0]])
    assert np.allclose(walker.box_px[1], [10, 20, 5, 12])
    assert walker.at_frame(1) == 1 and walker.at_frame(2) is None
    assert walker.seconds_visible == pytest.approx(0.1429)


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("0,0.0,7,ten,20,5,12,10,26,1.5,-2.0", r"truth\.csv:3: not a number"),
        ("0,0.0,7,10,20,5,12,10,26,nan,-2.0", r"truth\.csv:3: not finite"),
        ("0,0.0,7.5,10,20,5,12,10,26,1.5,-2.0", r"truth\.csv:3: frame and id must be whole"),
        ("0,0.0,7,10,20,0,12,10,26,1.5,-2.0", r"truth\.csv:3: the box must have a positive"),
        ("0,0.0,7,10,20,5,12,10,26,1.5", r"truth\.csv:3: not a number"),
    ],
)
def test_a_bad_line_is_named(tmp_path: Path, line: str, message: str) -> None:
    path = write(tmp_path, HEADER, "1,0.1429,7,10,20,5,12,10,26,1.5,-2.0", line)
    with pytest.raises(TruthFileError, match=message):
        read_truth(path)


def test_a_missing_column_or_a_repeated_frame_is_refused(tmp_path: Path) -> None:
    with pytest.raises(TruthFileError, match=r"truth\.csv:1: missing column\(s\) y_m"):
        read_truth(write(tmp_path, HEADER.replace(",y_m", ""), "0,0,1,1,1,1,1,1,1,1"))
    twice = write(tmp_path, HEADER, *["0,0.0,7,10,20,5,12,10,26,1.5,-2.0"] * 2)
    with pytest.raises(TruthFileError, match="person 7 is annotated twice"):
        read_truth(twice)
    with pytest.raises(TruthFileError, match="no annotations"):
        read_truth(write(tmp_path, HEADER))
    with pytest.raises(TruthFileError, match="cannot read"):
        read_truth(tmp_path / "absent.csv")


@pytest.mark.skipif(not PETS_TRUTH.is_file(), reason=f"the PETS truth is not at {PETS_TRUTH}")
def test_the_pets_truth_holds_its_ten_people() -> None:
    people = read_truth(PETS_TRUTH)
    assert len(people) == 10
    assert all(p.frame[0] >= 0 and p.frame[-1] <= 399 for p in people.values())
    assert np.allclose(people[9].t_s, people[9].frame / 7.0, atol=1e-3)
