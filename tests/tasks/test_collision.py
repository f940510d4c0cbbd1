"""tasks.collision: robot–sphere clearance (rod capsules and disk discs), batched."""

from __future__ import annotations

import numpy as np

from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.model.chain import PCCModel
from cdcr_gym.model.params import RobotParams
from cdcr_gym.tasks.collision import backend_geometry, clearance, model_geometry

P = RobotParams()
ROD, DISK = 0.5 * P.backbone_diameter, P.disk_radius


def _straight():
    return model_geometry(PCCModel(P), np.zeros((1, 1, 2)))


def test_a_sphere_beside_the_straight_robot_clears_the_nearest_disk_rim():
    # mid-height between the first two disks, 0.1 m from the axis: a disk rim is nearest
    h = P.length / P.n_disks
    sphere = np.array([[0.1, 0.0, 0.5 * h, 0.02]])
    gap = clearance(_straight(), sphere, ROD, DISK)
    np.testing.assert_allclose(gap, [[np.hypot(0.1 - DISK, 0.5 * h) - 0.02]], atol=1e-12)


def test_a_sphere_on_the_axis_above_the_tip_clears_the_rod_end():
    # on the axis above the tip: the disc face and the rod's rounded end are at the same height
    sphere = np.array([[0.0, 0.0, P.length + 0.1, 0.02]])
    gap = clearance(_straight(), sphere, ROD, DISK)
    np.testing.assert_allclose(gap, [[0.1 - ROD - 0.02]], atol=1e-12)


def test_a_sphere_over_a_disk_face_clears_by_its_height():
    # above the tip disk's face, within its radius: the disc is nearest
    sphere = np.array([[0.02, 0.0, P.length + 0.05, 0.01]])
    gap = clearance(_straight(), sphere, ROD, DISK)
    np.testing.assert_allclose(gap, [[0.05 - 0.01]], atol=1e-12)


def test_a_sphere_through_the_robot_has_negative_clearance_and_padding_is_inf():
    spheres = np.array([[0.0, 0.0, 0.3, 0.05], [0.0, 0.0, 0.0, 0.0]])
    gap = clearance(_straight(), spheres, ROD, DISK)
    assert gap[0, 0] < 0.0 and gap[0, 1] == np.inf


def test_backend_geometry_is_the_models_on_the_analytic_backend():
    robots = AnalyticBackend(P, num_robots=2)
    robots.apply_tensions(np.array([[40.0, 0.0, 0.0], [0.0, 20.0, 10.0]]))
    g = backend_geometry(robots)
    h = model_geometry(PCCModel(P), robots.bending)
    for a, b in zip(g, h):
        assert np.array_equal(a, b)
    assert g.points.shape[0] == 2 and g.disk_centres.shape == (2, P.n_disks + 1, 3)
