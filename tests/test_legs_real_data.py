"""detect_legs on the real, hand-labelled scans of ../shared/data/leg_tracker."""

from __future__ import annotations

from cobotsafety.sensors.evaluate_legs import evaluate_all


def test_detector_on_the_labelled_bags(shared_data):
    result = evaluate_all(shared_data / "leg_tracker")
    near = result["clip_1.4m"]
    far = result["range_5m_background"]
    assert near["scans"] == far["scans"] == 280  # 197 + 83 labelled scans
    # The paper's setting (1.4 m, no background): few labelled people that close; furniture
    # within 1.4 m gives false detections the paper's clean cell did not have.
    assert near["labelled_in_range"] == 36
    assert near["hit_rate"] >= 0.6
    assert near["torso_error_median_m"] <= 0.10
    # 5 m with a background estimated from the recording: most legs found, walls removed.
    assert far["hit_rate"] >= 0.7
    assert far["false_per_scan"] <= 0.6
    assert far["torso_error_median_m"] <= 0.10
    assert far["torso_error_p90_m"] <= 0.25
