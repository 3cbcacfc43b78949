"""Type stubs of the native module ``wavrad._native`` (PyO3)."""

from collections.abc import Callable
from os import PathLike
from typing import Any, Literal, final

import numpy as np
import numpy.typing as npt
from typing_extensions import TypeAlias, TypedDict, Unpack

__all__ = [
    "__version__",
    "ArgumentError",
    "Plan",
    "Projector",
    "Scene",
    "SceneError",
    "Solution",
    "SolveError",
    "SolveWarning",
    "WavradError",
    "load_scene",
    "plan",
    "projector",
    "read_exr",
    "relative_rmse",
    "solve",
    "write_image",
]

__version__: str
"""The version of wavrad (the Cargo workspace's)."""

_Path: TypeAlias = str | PathLike[str]
_Image: TypeAlias = npt.NDArray[np.float32]
_Progress: TypeAlias = bool | Callable[[str, int, int], object] | None

class _SolveSettings(TypedDict, total=False):
    """The settings :func:`solve` takes by keyword (documented there), as
    :func:`plan` and :func:`projector` take them."""

    threshold: float
    max_level: int
    three_point_threshold: float
    three_point_max_level: int
    three_point_receiver_levels: int
    tolerance: float
    max_iterations: int
    oracle: Literal["kernel", "power", "importance"]
    refine_passes: int
    cluster_ratio: float
    time_limit: float
    max_memory: float

class WavradError(Exception):
    """Base class of every wavrad error."""

class SceneError(WavradError):
    """A scene, mesh or image file could not be read or written (the message
    names the file and line), or bytes are not a block of links of this
    plan."""

class SolveError(WavradError):
    """The solver or renderer refused its input or failed (invalid settings,
    empty scene, no light, no sensor, a diverging solve, pixels not
    finite)."""

class SolveWarning(UserWarning):
    """A solve went on, but you should know: a time or memory limit (or
    Ctrl-C) cut it short, and what that left unrefined or out; linking
    coarsened because the limit was reached while linking; surface triples
    of glossy surfaces left out of a plan too large to hold. Warned where
    the call to wavrad was made, while the solve goes on (looked at every
    0.05 s) and when it returns. ``warnings`` filters apply: one that makes
    it an error stops the solve, as a ``progress`` callable that raises
    does, and raises it."""

class ArgumentError(WavradError, ValueError):
    """An argument wavrad cannot use (a wrongly typed setting, a wrongly
    shaped image, a plan used up); also a ``ValueError``. An unknown
    keyword raises ``TypeError``, as for any Python function."""

@final
class Scene:
    """A scene loaded from a Mitsuba 3 XML file."""

    @property
    def surface_count(self) -> int:
        """Number of surfaces (two-sided materials count twice)."""
    @property
    def sensor_count(self) -> int:
        """Number of sensors: views ``Solution.render(sensor=N)`` renders,
        numbered from 0 in the scene file's order (0: the first, rendered
        by default; ``width`` and ``height`` are its film's)."""
    @property
    def width(self) -> int:
        """Film width in pixels."""
    @property
    def height(self) -> int:
        """Film height in pixels."""

@final
class Solution:
    """A view-independent radiance solution."""

    def render(
        self,
        mode: Literal["gather", "direct", "smooth", "haar"] | None = None,
        spp: int | None = None,
        *,
        sensor: int = 0,
        origin: npt.ArrayLike | None = None,
        target: npt.ArrayLike | None = None,
        up: npt.ArrayLike | None = None,
        fov: float | None = None,
        eye: bool = True,
        gather_cache: bool = True,
        gather_spp: int | None = None,
        seed: int = 0,
        progress: _Progress = None,
    ) -> _Image:
        """Render the scene's sensor, or any other view of the solution, as an
        (height, width, 3) float32 array of linear RGB radiance.

        ``sensor``: which of the scene's sensors (:attr:`Scene.sensor_count`
        of them, numbered from 0 in the scene file's order; default the
        first), with its own film and sampler's ``sample_count``. Raises
        ``SolveError`` naming how many there are for one past the last.

        The solution is view-independent: ``origin``, ``target`` and ``up``
        (three numbers each) aim the sensor as Mitsuba's ``look_at`` does,
        and ``fov`` sets its field of view in degrees along the same axis as
        the scene's ``fov_axis``; the film stays the scene's. Anything not
        given keeps the scene camera's value: its position, its view
        direction (so a new ``origin`` alone moves the camera without turning
        it), its up axis, its field of view. Raises ``ArgumentError`` for a
        degenerate ``look_at`` (origin = target, up zero or along the view),
        a point that is not three finite numbers, a ``fov`` outside (0, 180)
        or a ``fov`` for an orthographic sensor.

        ``mode``: what camera rays show. ``"gather"`` (the default and most
        accurate) is a final gather at each visible point; the others read the
        solution along view rays, with no gather: ``"smooth"`` (the solution
        alone, bilinear between elements: what a lightmap holds), ``"haar"``
        (the piecewise-constant projection) or ``"direct"`` (the light straight
        from the emitters evaluated per camera ray, the rest of the solution
        smooth except across occluders' edges; glossy surfaces' radiance towards
        the eye per element). ``spp``: camera rays per pixel where an edge shows
        (default 256, or the scene sampler's sample_count if larger; pixels that
        show one surface get a quarter, and an eighth of those final-gather).
        ``eye``: for the modes that read the solution, glossy surfaces show
        their radiance gathered once into the eye as a hypothetical receiver
        (``True``), or read from the view-independent solution alone (``False``:
        the directional radiance towards what the view ray meets beyond the eye,
        or towards an enclosure receiver around the scene; no per-view work,
        softer highlights).
        ``gather_cache``: for ``"gather"``, diffuse surfaces read the light
        beyond the emitters' from a view-independent final gather, one gather
        per texel (half an element wide), gathered when a render first shows
        it and read by every later one, wherever that light varies slowly,
        and camera rays gather themselves only near other geometry (the
        default); ``False``: every gathering camera ray gathers.
        ``gather_spp``: for ``"gather"``, how many of an interior pixel's
        camera rays also final-gather (default ``spp`` / 32).
        ``seed``: scrambles every pixel's samples, as Mitsuba's sampler
        ``seed`` does (0 to 2³²−1): renders with different seeds have
        independent noise.
        ``progress``: as :func:`solve`'s; the render reports its rows as
        the phase ``"rendering"`` (``done`` of ``total`` rows; before it,
        the eye's links when a view gathers into it). Ctrl-C, or an
        exception the callable raises, stops the render within a row and
        is raised (``KeyboardInterrupt``) once it has: no image is
        returned, the solution is unchanged and can render again.
        Raises ``SolveError`` for an unknown mode, a value out of range, an
        option the mode has no use for (``eye=False`` with ``"gather"``,
        ``gather_cache=False`` with any other mode), a scene without a
        sensor and an image with pixels that are not finite (never returned);
        ``TypeError`` for an unknown keyword.
        """
    def save(self, path: _Path) -> None:
        """Write the solution to ``path`` as a solution file (the format of
        ``wavrad solve -o NAME.wavrad``), atomically: the scene, its
        elements, links, radiance and directional radiance, the settings
        and statistics, and the scene file and ``load_scene`` keywords it
        came from. :func:`load_solution` reads it back, in this process or
        another, and renders it without solving again. Raises
        ``SceneError`` naming the file if it cannot be written."""
    @property
    def radiance(self) -> npt.NDArray[np.float64]:
        """Average radiance of every element: an (elements, 3) float64
        array, surfaces in scene order, each surface's element hierarchy in
        the order of its nodes."""
    @property
    def directional(self) -> npt.NDArray[np.float64]:
        """Average directional radiance of every element pair of every
        glossy surface's directional structures, in the same way."""
    @property
    def stats(self) -> dict[str, Any]:
        """Statistics of the solve: ``two_point_nodes``,
        ``two_point_interactions``, ``three_point_nodes``,
        ``three_point_interactions``, ``nodes_per_level``, ``iterations``,
        ``residual``, ``converged``, ``times`` (seconds per phase),
        ``peak_memory_bytes``, ``settings`` (every setting of the solve by
        the name ``solve`` takes it: ``oracle``, ``threshold``,
        ``max_level``, ...), and how it was solved: ``solver``
        (``"gather"`` or ``"shoot"``), ``projections`` (made by the
        weighted oracles' refine-solve loop, at most ``refine_passes``),
        ``shooting_steps`` and
        ``unshot_fraction`` (0 when gathering), ``kernel_pairs`` (surface
        pairs whose kernels were projected) and ``exchanging_pairs``; and
        ``limited_leaves``, the leaves whose form factors summed so far
        above one that they would reflect more light than reached them,
        and whose reflection was scaled down; ``stopped`` and
        ``unrefined_items`` (what cut the solve short and what it left
        unrefined), ``resumed_items`` and ``projected_items`` (projection
        items kept from the solve resumed, and refined by this one);
        ``three_point_items`` (surface triples of glossy surfaces planned),
        ``unplanned_triples`` (the scene's triples past a plan's most, left
        out: their glossy surfaces reflect through distributions per bin
        instead) and ``left_out_items`` (planned triples a limit left out
        before they started), the last two without three-point links."""
    @property
    def checkpoint(self) -> tuple[int, int] | None:
        """For a solve cut short (``stats["stopped"]``), which
        ``solve(scene, resume=this)`` resumes: the projection items it
        finished and the items there are; ``None`` when it ran to the end.
        A solution file keeps it."""

def load_solution(path: _Path) -> Solution:
    """Read a solution file written by :meth:`Solution.save` or ``wavrad
    solve -o``; its renders are those of the solution that was saved.
    The scene file it was solved from is loaded again (with the same
    keywords) and compared with the one solved: a scene that changed since
    raises ``SceneError`` saying what differs; a scene file that is gone
    gives a ``UserWarning`` and the solution still renders. A file that is
    not a solution, of another format version, truncated or damaged raises
    ``SceneError`` naming the file and the problem."""

def load_scene(path: _Path, *, approximate: bool = False, **defines: object) -> Scene:
    """Load a Mitsuba 3 XML scene; keyword arguments override its
    ``<default>`` values (converted with ``str()``), like Mitsuba's ``-D``.
    ``approximate=True`` replaces every unsupported BSDF or texture by the
    nearest supported model, with one ``UserWarning`` per plugin saying what
    was substituted (the CLI's ``--approximate``).
    Raises ``SceneError`` naming the file and line, also for an override
    that no ``$name`` in the scene reads (as Mitsuba does); what is loaded but not
    as written (a mesh's triangles of zero area skipped, a sheared sphere
    kept a sphere) is reported as a ``UserWarning`` naming the file and
    line."""

def solve(
    scene: Scene,
    *,
    threshold: float | None = None,
    max_level: int | None = None,
    three_point_threshold: float | None = None,
    three_point_max_level: int | None = None,
    three_point_receiver_levels: int | None = None,
    tolerance: float | None = None,
    max_iterations: int | None = None,
    oracle: Literal["kernel", "power", "importance"] | None = None,
    refine_passes: int | None = None,
    cluster_ratio: float | None = None,
    time_limit: float | None = None,
    max_memory: float | None = None,
    solver: Literal["gather", "shoot"] | None = None,
    on_step: Callable[[dict[str, Any], _Image | None], bool | None] | None = None,
    progress: _Progress = None,
    resume: Solution | _Path | None = None,
    checkpoint: _Path | None = None,
    checkpoint_every: float = 300.0,
) -> Solution:
    """Solve ``scene``; the solve runs without the GIL.

    ``oracle``: the test that decides a link is fine enough: ``"kernel"``
    (the default and the paper's: Haar details of the kernel alone),
    ``"power"`` (the kernel's variation weighted by the radiance it carries,
    after Hanrahan et al. 1991) or ``"importance"`` (as ``"power"``, further
    weighted by the receiver's importance for the scene's sensor). The
    weighted oracles run a refine-solve loop of at most ``refine_passes``
    projections (default 4) and have their own default thresholds, in
    relative radiance error (2e-4 for ``threshold`` and
    ``three_point_threshold``); the keyword arguments below override them.

    ``threshold``: the oracle's threshold (kernel oracle: default 1e-3; the
    paper uses 1e-4); ``max_level``: deepest element level (default 5; the
    paper uses 8); ``three_point_threshold``: the oracle's threshold for
    three-point (glossy) links (kernel oracle: default 1e-5);
    ``three_point_max_level``: deepest element level of three-point (glossy)
    links (default 2); ``three_point_receiver_levels``: levels the receiving
    element of a three-point link may go further, for light straight from
    an emitter where the glossy lobe is sharp and narrower than the element
    (default 3; sharper highlights on diffuse receivers for no extra ray
    queries);
    ``tolerance``: convergence of the Gauss-Seidel sweeps
    (default 1e-5; when shooting, also the unshot power left, relative to
    the emitted power); ``max_iterations``: most sweeps (default 200; when
    shooting, also the most shooting steps); ``cluster_ratio``: largest
    (size of both ends)/distance of a link between clusters of surfaces
    (default 0.25; 0 links every pair of surfaces, as the paper does).

    ``time_limit`` (seconds, default 0: none) and ``max_memory`` (GiB,
    default 0: 80 % of the machine's memory) bound the solve: once one is
    reached, the surface pairs left are linked whole, without refinement,
    the sweeps stop after at least 8, and the solution is finished from
    what was done, with a :class:`SolveWarning` saying so (and another if
    the limit was reached while linking, which then links the pairs of
    clusters left as coarsely as ``cluster_ratio`` 0.9);
    ``stats["stopped"]`` names the limit (``"time_limit"``,
    ``"memory_limit"``) and ``stats["unrefined_items"]`` counts what it
    left unrefined (``None`` and 0 when nothing did).

    ``resume``: a solution cut short (by a limit or Ctrl-C), the path of
    its solution file, or the path of a checkpoint file (below): its solve
    is resumed. The links of the
    projection items it finished are kept, only the items it left are
    refined, and the solution is finished as an uninterrupted solve's (the
    same, bit for bit); ``stats["resumed_items"]`` counts the items kept
    and ``stats["projected_items"]`` those refined now. Its settings are
    kept, those given set on top, except ``time_limit`` and ``max_memory``,
    which are this call's own; ``scene`` must be the scene it solved.
    Raises ``SolveError`` (``cannot resume: ...``) for a solution that ran
    to the end (:attr:`Solution.checkpoint` is ``None``), another scene
    (naming what differs), or a setting that changes refinement given
    another value (naming it).

    ``checkpoint``: a file (``NAME.checkpoint.wavrad``) where a gathering
    solve saves what its kernel projection has finished, at most every
    ``checkpoint_every`` seconds (atomically), so that a process killed
    outright can be resumed from it (``resume=``). The solution is the same
    with or without checkpoints; the file is left in place when the solve
    returns. A save that fails gives one ``UserWarning`` and the solve goes
    on. ``load_solution`` refuses a checkpoint file: it is not a solution.

    ``solver``: ``"gather"`` (the default and the paper's: every kernel
    projected up front, then Gauss-Seidel gathering) or ``"shoot"``
    (progressive shooting from the emitters, kernels projected only where
    light flows, finished by Gauss-Seidel sweeps; diffuse scenes and the
    kernel and power oracles only). ``stats`` reports them as
    ``stats["settings"]["oracle"]`` and ``"solver"``, with
    ``"projections"``, ``"shooting_steps"``,
    ``"unshot_fraction"`` and ``"kernel_pairs"`` out of
    ``"exchanging_pairs"``.

    ``on_step``: with ``solver="shoot"``, called after every shooting step
    as ``on_step(step, image)``: ``step`` a dict with ``"index"`` (1, 2,
    ...), ``"shooter"`` (the surface shot), ``"unshot_fraction"``,
    ``"kernel_pairs"`` and ``"links"``; ``image`` the solution so far as a
    quick preview of the scene's sensor (smooth reconstruction, 4 camera
    rays per pixel; None without a sensor). Returning ``False`` stops
    shooting early (the Gauss-Seidel sweeps still finish the solution); an
    exception it raises stops shooting and is raised from ``solve``.

    ``progress``: how each phase (``"linking"``, ``"kernels"``, ``"3-point
    kernels"``, ``"emitter links"``, ``"solving"``, ``"shooting"``, ...)
    reports: ``True`` prints a line like tqdm's on ``sys.stderr`` (redrawn
    in place on a terminal, else one line at each phase's end and every
    10 s), ``False`` nothing, a callable is called as ``progress(phase,
    done, total)`` at each phase's start (``done`` 0), at most every 0.1 s
    during it and at its end, from any thread; default (``None``): ``True``
    where ``sys.stderr`` is a terminal, else ``False``. An exception the
    callable raises stops the solve, which finishes from what is done, and
    is raised from ``solve``. The first Ctrl-C does the same: the solve
    stops refining and sweeping, is finished from what is done
    (``stats["stopped"]`` is ``"interrupted"``) and returned, with a
    :class:`SolveWarning`; a second one raises ``KeyboardInterrupt`` once it has
    finished.

    Raises ``TypeError`` for an unknown keyword, ``ArgumentError`` for a value
    of the wrong type, a ``progress`` that is neither a bool nor callable,
    an ``on_step`` without ``solver="shoot"``, or ``resume`` with
    ``solver="shoot"``, and
    ``SolveError`` for a value outside its range (the message names the
    setting and the range), an unknown ``oracle`` or ``solver``, the
    importance oracle on a scene without a sensor, the shooting solver
    on a glossy scene or with the importance oracle, a scene where no
    surface emits (before any kernel work), and a solve whose Gauss-Seidel
    residual keeps growing (the message names the surfaces)."""

class Plan:
    """A gathering solve planned up to its kernel projection (:func:`plan`):
    the scene's ray queries, cluster tree and linking, which fix the
    projection's items (element pairs, then the surface triples of glossy
    surfaces). Each block of items can be projected anywhere: here
    (:meth:`project`), or as bytes (:meth:`items`) by a :class:`Projector`
    of the same scene and settings in another process; :meth:`finish`
    solves from every block's links, and the solution is :func:`solve`'s
    bit for bit.

    >>> plan = wavrad.plan(scene, threshold=1e-3)
    >>> worker = wavrad.projector(scene, **plan.settings)  # elsewhere
    >>> links = [worker.project(plan.items(block)) for block in plan.blocks(4)]
    >>> solution = plan.finish(links)
    """

    def __len__(self) -> int:
        """Projection items: element pairs, then surface triples."""
    def blocks(self, n: int) -> list[range]:
        """The items in at most ``n`` consecutive blocks, of sizes that
        differ by one at most (none without items)."""
    def project(self, block: range) -> bytes:
        """Project the items in ``block`` (a ``range`` with step 1; the GIL
        is released) and return their links as bytes for :meth:`finish`:
        a header naming the plan by its fingerprint, then the links in
        postcard. Raises ``SolveError`` for a block past the items and
        ``ArgumentError`` for a step other than 1."""
    def items(self, block: range) -> bytes:
        """The items in ``block`` (a ``range`` with step 1) as bytes for
        :meth:`Projector.project`: a header naming the scene, settings and
        plan by their fingerprints, then the element pairs and surface
        triples in postcard. Raises as :meth:`project` does."""
    def finish(self, blocks: list[bytes]) -> Solution:
        """Solve from the projected ``blocks``, which must hold every item
        once, in any order: the emitters' links carried down, the element
        hierarchies built, the Gauss-Seidel sweeps (and the weighted
        oracles' refine-solve loop) run here. The plan is used up; using it
        again raises ``ArgumentError``. Raises ``SceneError`` for bytes that
        are not a block or were projected from another plan (another scene,
        other settings), and ``SolveError`` for blocks that leave items out
        or hold some twice; the plan is kept then."""
    def links_in(self, block: bytes) -> tuple[int, int]:
        """The two-point and three-point links in ``block``, bytes that
        :meth:`project` of this plan returned."""
    @property
    def settings(self) -> dict[str, Any]:
        """Every setting of the plan by the name :func:`plan` takes it:
        planning the same scene again with them makes the same plan."""
    @property
    def fingerprint(self) -> int:
        """The CRC-32 of the plan's scene, settings and items, which its
        blocks carry."""
    @property
    def projector_fingerprint(self) -> int:
        """The CRC-32 of the plan's scene and settings: the
        :attr:`Projector.fingerprint` of a projector that can project its
        items."""

@final
class Projector:
    """What projects a plan's items in a process that did not plan
    (:func:`projector`): the scene, its ray queries and the settings,
    without the linking."""

    def project(self, items: bytes) -> bytes:
        """Project ``items`` (bytes from :meth:`Plan.items` of a plan of the
        same scene and settings; the GIL is released) and return their
        links as bytes for that plan's :meth:`Plan.finish`. Raises
        ``SceneError`` for bytes that are not a block's items or were made
        for another scene or other settings."""
    @property
    def fingerprint(self) -> int:
        """The CRC-32 of the scene (its surfaces, camera and film), the
        settings and wavrad's version."""

def plan(
    scene: Scene,
    **settings: Unpack[_SolveSettings],
) -> Plan:
    """Plan the gathering solve of ``scene`` with :func:`solve`'s settings,
    for its kernels to be projected in blocks elsewhere (:class:`Plan`,
    :mod:`wavrad.distributed`). Raises as :func:`solve` does."""

def projector(
    scene: Scene,
    **settings: Unpack[_SolveSettings],
) -> Projector:
    """What projects the items of plans of ``scene`` with :func:`solve`'s
    settings (pass a plan's :attr:`Plan.settings`), in a process that did
    not plan. Raises as :func:`solve` does."""

def relative_rmse(a: npt.ArrayLike, b: npt.ArrayLike) -> float:
    """Relative RMSE of ``a`` against the reference ``b``:
    ``sqrt(mean((a - b)**2)) / mean(b)``."""

def read_exr(path: _Path) -> _Image:
    """Read the RGB channels of an OpenEXR file as an (height, width, 3)
    float32 array. Raises ``SceneError`` naming the file."""

def write_image(path: _Path, image: npt.ArrayLike) -> None:
    """Write an (height, width, 3) linear RGB array as ``.exr`` (float) or
    ``.png`` (8-bit sRGB), chosen by extension."""
