"""The vocabulary's names agree with the configuration files that define them."""

from __future__ import annotations

from campaign.core import vocabulary
from campaign.core.yamlfile import config_file, read_yaml


def test_base_and_gain_names_are_the_papers():
    paper = read_yaml(config_file("paper.yaml"))
    assert (vocabulary.FIXED, vocabulary.FLEXIBLE) == tuple(paper["bases"]) == vocabulary.bases()
    assert (vocabulary.ZERO, vocabulary.LOW, vocabulary.HIGH) == tuple(paper["gains"]) == vocabulary.gain_sets()
    assert vocabulary.gain_classes() == {vocabulary.ZERO_LOW: (vocabulary.ZERO, vocabulary.LOW),
                                         vocabulary.HIGH: (vocabulary.HIGH,)}


def test_structure_names_are_the_rigs():
    rig = read_yaml(config_file("rig.yaml"))
    assert {vocabulary.STIFF_MAST, vocabulary.SPACE_CLASS} == set(rig["structures"])
    assert rig["flexible"]["structure"]["value"] in (vocabulary.STIFF_MAST, vocabulary.SPACE_CLASS)


def test_names_are_every_name_the_files_define():
    """The set the layout test looks for: each base, gain set, gain class and structure."""
    paper, rig = read_yaml(config_file("paper.yaml")), read_yaml(config_file("rig.yaml"))
    assert vocabulary.NAMES == {*paper["bases"], *paper["gains"], *paper["gain_classes"], *rig["structures"]}
