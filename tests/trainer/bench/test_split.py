"""The tune/check split of the shared data (svbrdf.trainer.bench.split): by material and by capture."""

import pytest

from svbrdf.runtime.errors import SvbrdfError
from svbrdf.trainer.bench import split as S

DES18 = "weiyi-auxrender/test_data/Des18/gt-material/"
DES19 = "weiyi-auxrender/test_data/Des19/gt-material/"


def test_ground_truth_sets_go_by_family_and_mixtures_of_both_sides_go_nowhere():
    assert S.split_of(DES19 + "10_brick_uneven_stones") == "tune"
    assert S.split_of(DES19 + "36_leather_tiles") == "tune"
    assert S.split_of(DES19 + "13_PolishedMarbleFloor_01") == "check"
    assert S.split_of(DES19 + "27_metal_bumpy_squares") == "check"
    assert S.split_of(DES18 + "0000026;leather_tilesXbrick_uneven_stones;defaultX1") == "tune"
    assert S.split_of(DES18 + "0000001;PolishedMarbleFloor_01Xmetal_bumpy_squares;1X1") == "check"
    assert S.split_of(DES18 + "0000011;metal_bumpy_squaresXbrick_uneven_stones;1X1") == S.MIXED
    assert not set(S.TUNE_FAMILIES) & set(S.CHECK_FAMILIES)


def test_every_view_of_a_capture_is_on_one_side():
    views = [f"guo-svbrdf-diff-renderer/bath_tile/{i:02d}" for i in range(9)]
    assert {S.split_of(v) for v in views} == {"tune"}


def test_a_photo_is_keyed_by_its_camera_number_so_one_material_in_two_folders_is_on_one_side():
    a = S.split_of("deschaintre18-real/IMG_6966")
    assert S.split_of("weiyi-auxrender/test_data/real/IMG_6966-inputs_input") == a
    assert S.materials("xuejiao-lgd/dataset/IMG_6970-inputs") == ("IMG_6970",)
    assert S.materials("deschaintre18-real/IMG_20180104_210434") == ("IMG_20180104_210434",)
    # the rule, not a choice per photo: both sides occur among photos
    sides = {S.split_of(f"henzler-flash/test/{i}/IMG_{9390 + i}") for i in range(12)}
    assert sides == {"tune", "check"}


def test_select_split_keeps_order_and_rejects_an_unknown_part():
    names = [DES19 + "10_brick_uneven_stones", DES19 + "13_PolishedMarbleFloor_01", DES19 + "9_brick_uneven_stones"]
    assert S.select_split(names, "tune") == [names[0], names[2]]
    assert S.select_split(names, "check") == [names[1]]
    with pytest.raises(SvbrdfError, match="unknown split"):
        S.select_split(names, "train")
    table = S.split_table(names)
    assert table == {"weiyi-auxrender": {"tune": 2, "check": 1, "mixed": 0}}
