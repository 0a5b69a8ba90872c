"""The simulated desk's cheaper drawing gives the same pictures (issue 28: the Pi 4 budget).

A render finishes (camera LUT, lens blur) only the boxes where something was painted over the
bare desk, masks and blurs shadows in groups (a still group keeps its blurred patch), pastes a
still thing's (or an idle arm's) pixels when they were painted over the same background before,
and adds the noise as two 8-bit fields. Each of these is checked here against the plain way of
doing it, to the bit. Markers are warped at 3× (the one change in the pictures: the accuracy
tests in test_simdesk and tests/vision hold), the arm's plate still at 4×.
"""
import struct
import zlib

import cv2
import numpy as np
import pytest

from core.handeye import ToolMarker
from core.settings import CameraSettings
from core.sim import desk as desk_module
from core.sim.desk import SIDES, SimDesk
from core.sim.rig import SimRig

# base → shoulder → elbow → tool (robot_base, m); moved a little per frame so the arm's shadow moves
ARM = np.array([(0.0, 0.0, 0.0), (0.0, 0.0, 0.066), (0.0, 0.06, 0.17), (0.0, 0.15, 0.12)])


@pytest.fixture(scope="module")
def rig():
    return SimRig()


def arm_at(k: int) -> np.ndarray:
    return ARM + np.array([0.004 * k, 0.002 * k, 0.0])


def render_plainly(desk: SimDesk, t: float, arm) -> list[np.ndarray]:
    """``render``'s images with the whole image finished (LUT, blur, noise), as renders were made
    before the finish learned to do only the painted boxes."""
    st = desk.scene(t)
    shadows3 = desk._shadow_polygons(st, arm)
    images = []
    for i, side in enumerate(SIDES):
        view = desk._views[side]
        img, _ = desk._draw(view, desk._layout(view, st, arm), shadows3)
        images.append(desk._finish(img, t, i))  # no view, no boxes: the whole image
    return images


def shadows_in_one_mask(img: np.ndarray, view, polys3: list) -> None:
    """The shadows as one mask over the bounds of them all, blurred at once (the reference)."""
    h_img, w_img = img.shape[:2]
    polys = [p for p in (view.project_polygon(q) for q in polys3) if p is not None]
    if not polys:
        return
    allp = np.vstack(polys)
    pad = int(3 * desk_module.SHADOW_BLUR_PX) + 2
    x0, y0 = np.floor(allp.min(axis=0)).astype(int) - pad
    x1, y1 = np.ceil(allp.max(axis=0)).astype(int) + pad
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w_img), min(y1, h_img)
    if x1 <= x0 or y1 <= y0:
        return
    mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
    origin = np.array([x0, y0], dtype=float)
    for p in polys:
        cv2.fillPoly(mask, [np.round((p - origin) * 16.0).astype(np.int32)],
                     int(round(255 * desk_module.SHADOW_DARKNESS)), lineType=cv2.LINE_AA, shift=4)
    mask = cv2.GaussianBlur(mask, (0, 0), desk_module.SHADOW_BLUR_PX)
    roi = img[y0:y1, x0:x1]
    cv2.multiply(roi, cv2.merge([cv2.subtract(255, mask)] * 3), dst=roi, scale=1.0 / 255.0)


def assert_same_images(got, expected, what):
    for side, a, b in zip(SIDES, got, expected):
        diff = int(np.abs(a.astype(int) - b.astype(int)).max())
        assert diff == 0, f"{what}, {side} view: differs from the plain finish by up to {diff} levels"


# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("scenario, times", [
    ("objects", [5.6 + k / 30 for k in range(4)]),  # the hand over the disc, balls and plush moving
    ("wander", [11.0 + k / 30 for k in range(4)]),  # markers moving, the hand sweeping across
    ("panel", [0.0, 1 / 30]),  # textures (the plate, the buttons)
])
def test_finishing_only_the_painted_boxes_gives_the_whole_image_finish(rig, scenario, times):
    desk = SimDesk(rig, scenario=scenario)
    reference = SimDesk(rig, scenario=scenario)
    for k, t in enumerate(times):
        left, right, _ = desk.render(t, arm_at(k))
        assert_same_images((left, right), render_plainly(reference, t, arm_at(k)), f"{scenario} at t={t:.3f}")


@pytest.mark.parametrize("options, settings", [
    (dict(blur_sigma_px=1.7, noise_sigma=6.0), CameraSettings()),  # a wider kernel: a wider reach
    (dict(), CameraSettings(exposure=0.8, gain=6.0, brightness=-10.0, contrast=1.4)),  # with the LUT
    (dict(blur_sigma_px=0.0), CameraSettings(contrast=1.5)),  # the LUT alone
])
def test_the_box_finish_holds_for_other_blurs_and_camera_settings(rig, options, settings):
    desk = SimDesk(rig, scenario="objects", **options)
    reference = SimDesk(rig, scenario="objects", **options)
    for d in (desk, reference):
        d.set_camera_settings(settings)
    for k, t in enumerate([5.6, 5.6 + 1 / 30]):
        left, right, _ = desk.render(t, arm_at(k))
        assert_same_images((left, right), render_plainly(reference, t, arm_at(k)), f"{options} {settings}")
    desk.set_camera_settings(CameraSettings())  # the finished bare desk follows a change of settings
    reference.set_camera_settings(CameraSettings())
    left, right, _ = desk.render(6.0, ARM)
    assert_same_images((left, right), render_plainly(reference, 6.0, ARM), "back to the default settings")


def test_noise_as_two_8_bit_fields_equals_the_saturating_int16_sum(rig):
    """Noise large enough to saturate both ways and to pass ±255 (gain 24 dB, contrast 3)."""
    desk = SimDesk(rig, scenario="static", blur_sigma_px=0.0, noise_sigma=30.0, seed=5)
    desk.set_camera_settings(CameraSettings(gain=24.0, contrast=3.0))
    w, h = rig.size
    img = np.random.default_rng(1).integers(0, 256, (h, w, 3), dtype=np.uint8)
    img[:40] = 0
    img[40:80] = 255
    sigma = desk.effective_noise_sigma
    assert sigma > 255
    # the int16 field and its mixed-type add, as the desk drew its noise before
    noise = np.empty((h + desk_module.NOISE_SHIFTS, w + desk_module.NOISE_SHIFTS), np.float32)
    cv2.setRNGSeed(zlib.crc32(struct.pack("<qd", desk.seed, sigma)) & 0x7FFFFFFF)
    cv2.randn(noise, 0.0, sigma)
    field = np.round(cv2.cvtColor(noise, cv2.COLOR_GRAY2BGR)).astype(np.int16)
    for t, side in [(0.0, 0), (1.25, 1), (7.5, 2)]:
        key = zlib.crc32(struct.pack("<qdq", desk.seed, t, side))
        dy, dx = key % desk_module.NOISE_SHIFTS, (key // desk_module.NOISE_SHIFTS) % desk_module.NOISE_SHIFTS
        expected = cv2.add(cv2.LUT(img, desk._lut), field[dy:dy + h, dx:dx + w], dtype=cv2.CV_8U)
        got = desk._finish(img.copy(), t, side)
        assert np.array_equal(got, expected), f"t={t} side={side}: up to {np.abs(got.astype(int) - expected).max()} levels off"


def test_grouped_shadows_equal_one_mask_over_all_of_them_and_still_groups_are_kept(rig):
    desk = SimDesk(rig, scenario="objects")
    view = desk._views["left"]
    for k, (t, a) in enumerate([(0.0, 0), (0.0, 0), (5.6, 1), (5.6 + 1 / 30, 2), (5.6 + 2 / 30, 3)]):
        polys3 = desk._shadow_polygons(desk.scene(t), arm_at(a))
        got, expected = view.desk.copy(), view.desk.copy()
        patches_before = len(view.shadow_patches)
        dirty: list = []
        desk._draw_shadows(got, view, polys3, dirty)
        shadows_in_one_mask(expected, view, polys3)
        diff = int(np.abs(got.astype(int) - expected).max())
        assert diff == 0, f"t={t}: the grouped shadows differ from one mask by up to {diff} levels"
        assert len(dirty) >= 2  # the shadows fall in several groups (not one box over them all)
        changed = np.any(got != view.desk, axis=2)
        inside = np.zeros_like(changed)
        for x0, y0, x1, y1 in dirty:
            inside[y0:y1, x0:x1] = True
        assert not np.any(changed & ~inside), "a shadow darkened a pixel outside the boxes it reported"
        if k == 1:  # the same scene again: every group's blurred patch was kept
            assert len(view.shadow_patches) == patches_before


def test_a_still_things_pixels_are_pasted_only_over_the_background_they_were_painted_on(rig):
    desk = SimDesk(rig, scenario="objects")
    view = desk._views["left"]
    st = desk.scene(0.0)
    item = desk._cached_thing_item(view, st.things[1])  # the green ball: still
    assert item.keep_pixels and item is desk._cached_thing_item(view, st.things[1])
    plain = view.desk.copy()
    grey = np.full_like(plain, 90)

    def painted_plainly(background):
        img = background.copy()
        for sh in item.shapes:
            cv2.fillPoly(img, [np.round(sh.pts * 16.0).astype(np.int32)], sh.colour, lineType=cv2.LINE_AA, shift=4)
        for pts, colour, closed in item.lines:
            cv2.polylines(img, [np.round(pts * 16.0).astype(np.int32)], closed, colour, 1,
                          lineType=cv2.LINE_AA, shift=4)
        return img

    for background in (plain, plain, grey, plain, grey, grey):
        img = background.copy()
        box = SimDesk._paint_shapes(img, item)
        assert np.array_equal(img, painted_plainly(background))
        changed = np.argwhere(np.any(img != background, axis=2))
        assert len(changed)
        (y0, x0), (y1, x1) = changed.min(axis=0), changed.max(axis=0)
        assert box[0] <= x0 and box[1] <= y0 and x1 < box[2] and y1 < box[3]  # the box holds what it painted


@pytest.mark.parametrize("scenario, t0, arm_moves", [("objects", 5.5, True), ("objects", 5.5, False),
                                                    ("wander", 11.0, True), ("cups", 3.0, False)])
def test_frame_after_frame_the_renders_equal_a_fresh_desks(rig, scenario, t0, arm_moves):
    """Whatever the desk keeps from frame to frame (still items' pixels, shadow patches, the
    finished bare desk, card items, an idle arm's items), each frame is that of a desk that
    never rendered before."""
    tool = ToolMarker()  # the default robot's plate
    desk = SimDesk(rig, scenario=scenario, tool_marker=tool)
    for k in range(5):
        t = t0 + k / 30
        arm = arm_at(k if arm_moves else 0)
        left, right, truth = desk.render(t, arm)
        fresh = SimDesk(rig, scenario=scenario, tool_marker=tool).render(t, arm)
        assert_same_images((left, right), fresh[:2], f"{scenario} frame {k}")
        assert truth == fresh[2]


def test_an_idle_arms_items_are_made_once_and_kept_while_it_stays_still(rig, monkeypatch):
    desk = SimDesk(rig, scenario="objects")
    made, real = [], SimDesk._arm_items
    monkeypatch.setattr(SimDesk, "_arm_items", lambda self, view, pts: made.append(view.side) or real(self, view, pts))
    for t in (0.0, 1 / 30, 2 / 30):
        desk.render(t, ARM)
    assert sorted(made) == ["left", "right"]  # once per view
    desk.render(3 / 30, arm_at(1))  # it moved: made again
    assert len(made) == 4


def test_markers_are_warped_at_3x_and_the_tool_plate_at_4x_with_anti_aliased_edges(rig, monkeypatch):
    """Cards (and cups, wristbands) at MARKER_SUPERSAMPLE: a moving marker is warped every frame;
    the plate the arm carries — what the hand-eye sweep measures — stays at SUPERSAMPLE."""
    tool = ToolMarker()  # the default robot's plate
    desk = SimDesk(rig, scenario="static", tool_marker=tool, blur_sigma_px=0.0, noise_sigma=0.0)
    warps, real = [], SimDesk._warp_patch
    monkeypatch.setattr(SimDesk, "_warp_patch", staticmethod(lambda shape, tex, H, paper, S: warps.append(S)
                                                             or real(shape, tex, H, paper, S)))
    left, _, _ = desk.render(0.0, ARM)
    assert desk_module.MARKER_SUPERSAMPLE == 3 and desk_module.SUPERSAMPLE == 4
    assert sorted(warps) == [3, 3, 3, 3, 4, 4]  # two cards and the plate, in each view
    # the edges carry coverage: levels between paper white and print black round each card
    bare = desk._views["left"].desk
    painted = np.any(left != bare, axis=2)
    grey = left.astype(int).mean(axis=2)
    between = painted & (grey > desk_module.MARKER_BLACK + 20) & (grey < desk_module.MARKER_WHITE - 20)
    assert between.sum() > 50


def test_render_camera_is_unchanged_by_the_rig_views_caches(rig):
    """A camera elsewhere (the hand camera's hook) finishes its whole image; the rig views'
    kept state does not leak into it."""
    desk = SimDesk(rig, scenario="objects")
    T = rig.base_T_left.copy()
    T[0, 3] += 0.04
    desk.render(5.6, ARM)
    image, _ = desk.render_camera(T, rig.K, (320, 240), 5.6)
    again, _ = SimDesk(rig, scenario="objects").render_camera(T, rig.K, (320, 240), 5.6)
    assert np.array_equal(image, again)


def test_after_a_frame_without_bounds_the_next_frames_are_drawn_on_a_clean_desk(rig, monkeypatch):
    """An item whose outline has no bound (NaN, or px beyond fillPoly's range) sends the frame
    through the whole-image finish (the LUT then changes the kept canvas everywhere); the frames
    after it still equal a fresh desk's."""
    desk = SimDesk(rig, scenario="wander")
    desk.set_camera_settings(CameraSettings(contrast=1.3))
    real = desk_module._item_box
    monkeypatch.setattr(desk_module, "_item_box", lambda it: (real(it), ())[1])  # its outlines made, no bound
    desk.render(11.0, ARM)
    monkeypatch.setattr(desk_module, "_item_box", real)
    for k in range(1, 4):
        t = 11.0 + k / 30
        fresh = SimDesk(rig, scenario="wander")
        fresh.set_camera_settings(CameraSettings(contrast=1.3))
        left, right, _ = desk.render(t, arm_at(k))
        assert_same_images((left, right), fresh.render(t, arm_at(k))[:2], f"frame {k} after the unbounded one")


# -- shadows blurred side by side, the plush's hulls at once, still targets' visibility kept ------


def test_shadow_masks_blurred_side_by_side_equal_a_blur_of_each(rig):
    """Masks of every shape — tiny, thin, tall, wide, touching their edges, full of texture (what
    BORDER_REFLECT_101 mirrors matters there) or empty — give the pixels of one GaussianBlur each."""
    rng = np.random.default_rng(3)
    for trial in range(300):
        masks = []
        for _ in range(int(rng.integers(1, 7))):
            h = int(rng.integers(1, 15) if rng.random() < 0.2 else rng.integers(1, 400))
            w = int(rng.integers(1, 15) if rng.random() < 0.2 else rng.integers(1, 500))
            m = np.zeros((h, w), np.uint8)
            for _ in range(int(rng.integers(0, 4))):
                pts = rng.uniform(-10, max(h, w) + 10, (int(rng.integers(3, 8)), 2))
                cv2.fillPoly(m, [np.round(pts * 16).astype(np.int32)], int(rng.integers(1, 256)), cv2.LINE_AA, 4)
            if rng.random() < 0.1:
                m[:] = rng.integers(0, 256, m.shape)
            masks.append(m)
        for k, (m, got) in enumerate(zip(masks, desk_module._blur_shadow_masks(masks))):
            expected = cv2.GaussianBlur(m, (0, 0), desk_module.SHADOW_BLUR_PX)
            assert got.shape == expected.shape and np.array_equal(got, expected), \
                f"trial {trial}, mask {k} {m.shape}: up to {np.abs(got.astype(int) - expected).max()} levels off"


def test_a_frames_moving_shadow_groups_are_blurred_in_one_call_per_view(rig, monkeypatch):
    """The objects scene with the arm moving: the shadow groups that change (the arm's, the
    balls', the plush's) are blurred side by side, one blur call a view, not one per group."""
    desk = SimDesk(rig, scenario="objects", tool_marker=ToolMarker())
    desk.render(0.0, arm_at(0))
    calls, groups, real_blur, real_masks = [], [], cv2.GaussianBlur, desk_module._blur_shadow_masks
    monkeypatch.setattr(cv2, "GaussianBlur", lambda src, *a, **kw: calls.append(src.shape) or real_blur(src, *a, **kw))
    monkeypatch.setattr(desk_module, "_blur_shadow_masks", lambda masks: groups.append(masks) or real_masks(masks))
    desk.render(1 / 30, arm_at(1))
    assert [len(masks) for masks in groups] == [2, 2]  # per view, the groups that changed
    shadow_calls = [shape for shape in calls if len(shape) == 2]  # (the finish blurs colour images)
    r = desk_module.SHADOW_BLUR_REACH_PX
    assert shadow_calls == [(max(m.shape[0] for m in masks) + r, sum(m.shape[1] + 2 * r for m in masks))
                            for masks in groups]


def plush_hulls_one_at_a_time(view, th) -> list:
    """The plush's five hulls as _plush_item made them before they were placed at once."""
    a, b = th.radius_m, th.height_m / 2
    axes = np.array([a, b, b])
    c, s = np.cos(th.yaw), np.sin(th.yaw)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    centre3 = np.array(th.centre)
    local = desk_module._SPHERE * axes
    to_cam = view.cam_pos - centre3
    half = desk_module.LIGHT + to_cam / np.linalg.norm(to_cam)
    n_local = R.T @ (half / np.linalg.norm(half))
    spot_local = axes**2 * n_local / np.linalg.norm(axes * n_local)

    def hull(scale, towards):
        px, _ = view.project(centre3 + (towards * (1 - scale) + local * scale) @ R.T)
        return cv2.convexHull(px.astype(np.float32))[:, 0, :].astype(np.float64)

    return [hull(1.0, np.zeros(3))] + [hull(k, 0.75 * spot_local) for k in (0.86, 0.66, 0.42)] \
        + [hull(0.14, 0.9 * spot_local)]


def test_the_plushs_hulls_placed_and_projected_at_once_equal_one_hull_at_a_time(rig):
    desk = SimDesk(rig, scenario="objects")
    for t in np.linspace(0.0, 5.5, 12):  # it slides and turns
        plush = next(th for th in desk.scene(t).things if th.kind == "plush")
        for side in SIDES:
            view = desk._views[side]
            got = [sh.pts for sh in desk._plush_item(view, plush).shapes]
            expected = plush_hulls_one_at_a_time(view, plush)
            assert len(got) == 5 and all(np.array_equal(g, e) for g, e in zip(got, expected)), f"t={t:.2f} {side}"


def test_a_still_targets_visibility_is_kept_while_the_same_items_may_cover_it(rig, monkeypatch):
    """The objects scene frozen: the second frame masks no target (the first did: still things
    overlap still things in a view). Moving the hand over the orange disc and away, every frame's
    truth is a fresh desk's, and the disc's flag does change."""
    desk = SimDesk(rig, scenario="objects")
    masked, real_fill = [], desk_module._fill
    monkeypatch.setattr(desk_module, "_fill",
                        lambda img, pts, colour, aa=True: (masked.append(aa) if not aa else None) or real_fill(img, pts, colour, aa))
    desk.truth(0.0, ARM)
    first = len(masked)
    desk.truth(0.0, ARM)
    assert first > 0 and len(masked) == first
    monkeypatch.setattr(desk_module, "_fill", real_fill)
    seen = set()
    for t in np.arange(4.5, 10.5, 0.25):  # the hand comes (5 s), hovers, goes (11 s)
        truth = desk.truth(t, ARM)
        assert truth == SimDesk(rig, scenario="objects").truth(t, ARM), f"t={t:.2f}"
        seen.add(next(o.visible_left for o in truth.objects if o.label == "orange disc"))
    assert seen == {True, False}


def test_a_hands_outlines_and_shadows_placed_at_once_equal_one_at_a_time(rig):
    """Hands across the views, one so near a camera that its outlines cross the near plane (those
    are clipped as project_polygon clips them)."""
    from core.sim.scenarios import Hand, SceneState

    desk = SimDesk(rig, scenario="objects")
    left = desk._views["left"]
    hands = [Hand(0.1, 0.2, 0.1, 1.2), Hand(-0.2, 0.35, 0.05, -0.4), Hand(0.3, 0.1, 0.15, 3.0),
             Hand(*left.cam_pos[:2], left.cam_pos[2] - 0.03, 0.3)]  # just below the left camera
    clipped = 0
    drop = np.array([desk_module.LIGHT[0] / desk_module.LIGHT[2], desk_module.LIGHT[1] / desk_module.LIGHT[2], 1.0])
    for hand in hands:
        pose = (hand.x, hand.y, hand.z, hand.yaw)
        for view in desk._views.values():
            outlines = [view.project_polygon(desk._local_to_base(pose, o)) for o in desk_module._HAND_OUTLINES]
            gaps = [view.project_polygon(desk._local_to_base(pose, np.array(g))) for g in desk_module._HAND_GAPS]
            clipped += any(p is not None and len(p) != len(o) for p, o in zip(outlines, desk_module._HAND_OUTLINES))
            item = desk._hand_item(view, hand)
            expected = [p for p in outlines if p is not None]
            if not expected:
                assert item is None
                continue
            assert len(item.shapes) == len(expected)
            assert all(np.array_equal(sh.pts, p) for sh, p in zip(item.shapes, expected))
            expected_lines = [p for p in gaps if p is not None and len(p) == 2]
            assert len(item.lines) == len(expected_lines)
            assert all(np.array_equal(line[0], p) for line, p in zip(item.lines, expected_lines))
        shadows = desk._shadow_polygons(SceneState(hands=(hand,)), None)
        expected = [o3 - o3[:, 2:3] * drop for o3 in (desk._local_to_base(pose, o) for o in desk_module._HAND_OUTLINES)]
        assert len(shadows) == 3 and all(np.array_equal(s, e) for s, e in zip(shadows, expected))
    assert clipped  # the near hand's outlines were clipped in a view


def test_an_item_keeps_its_pixels_from_its_second_painting_on(rig):
    """A moving thing's or moving arm's item is made anew each frame and painted once: nothing of
    it is copied. A still thing's item keeps its pixels when painted a second time and pastes
    them from the third on."""
    desk = SimDesk(rig, scenario="objects")
    view = desk._views["left"]

    def items_of(t, arm):
        st = desk.scene(t)
        flat, solid = desk._cached_arm_items(view, arm)
        things = {th.label: desk._cached_thing_item(view, th) for th in st.things}
        return flat + solid, things

    kept_after = []
    for k in range(3):
        t, arm = k / 30, arm_at(k)
        desk.render(t, arm)
        arm_items, things = items_of(t, arm)
        assert all(it.kept is desk_module._PAINTED_ONCE for it in arm_items if it.shapes)  # (moved each frame)
        assert things["red ball"].kept is desk_module._PAINTED_ONCE  # it rolls: a new item each frame
        kept_after.append(things["green ball"].kept)
    assert kept_after[0] is desk_module._PAINTED_ONCE
    assert len(kept_after[1]) == 3 and kept_after[2] is kept_after[1]  # kept, then pasted


def test_a_moving_arms_base_plate_is_made_once_per_view_and_pastes_its_pixels(rig):
    """The arm moves, its base stays on the desk: the base plate's item is the same each frame
    (kept pixels pasted), the links and joints are new; every frame equals a fresh desk's."""
    desk = SimDesk(rig, scenario="objects")
    view = desk._views["left"]
    bases, links = [], []
    for k in range(3):
        arm = ARM.copy()
        arm[1:] += np.array([0.003 * k, 0.002 * k, 0.0])  # the base point stays, the rest moves
        left, right, _ = desk.render(k / 30, arm)
        flat, solid = desk._cached_arm_items(view, arm)
        bases.append(flat[0])
        links.append(solid[0])
        assert_same_images((left, right), SimDesk(rig, scenario="objects").render(k / 30, arm)[:2], f"frame {k}")
    assert bases[0] is bases[1] is bases[2] and links[0] is not links[1]
    assert len(bases[2].kept) == 3  # (painted on the bare desk each time: kept, then pasted)
