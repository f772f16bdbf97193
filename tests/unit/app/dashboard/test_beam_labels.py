"""The beams' numbers in the 3-D view stand on their beams in every frame of a playback."""

from __future__ import annotations

import numpy as np
import pytest
import viser

from app.dashboard.session_scene import beam_label_positions_view
from app.dashboard.truth_view import truth_view
from app.figures.scene import beam_label_positions_b, ned_to_view
from tauvcore.config import Config
from tests.unit.helpers.scene_view import scene_view


def test_the_beam_labels_move_with_the_hull_in_the_same_batch_not_under_it() -> None:
    """viser places a label from its parent's world matrix of the frame before: a label under the
    moving hull trailed its beam during Play. The labels hang from the view's frame and show_time
    places each where the hull's pose puts its body-frame position, with the hull."""
    with scene_view() as (view, state):
        assert [label.name for label in view.beam_labels] == [f"/beam_labels/{k}" for k in range(1, 5)]
        config = Config().replace("trajectory", name="figure8", duration_s=30.0)
        state.config, state.truth_view = config, truth_view(config, 15)
        view.draw_truth()
        view.show_time(17.3)
        hull = np.array(view.auv.position)
        rotation = viser.transforms.SO3(np.array(view.auv.wxyz)).as_matrix()
        p_b = beam_label_positions_b(config.dvl.l_dvl_b, config.dvl.A_b)
        for label, p in zip(view.beam_labels, p_b):
            # the mesh's body frame placed by the hull's pose: what a child of /auv would show
            assert np.array(label.position) == pytest.approx(hull + rotation @ p, abs=1e-6)
        np.testing.assert_allclose(beam_label_positions_view(config, np.zeros(3), np.eye(3)), ned_to_view(p_b))
