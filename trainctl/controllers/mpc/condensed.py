# Building blocks of condensed MPC problems, shared by the MPC core and the train MPC.
"""Condensed MPC building blocks: move maps, input rows and QP blocks.

A condensed MPC decides the plan U (M moves of nu inputs, ordered move by
move) with the states eliminated through the prediction Y = Φx + S_u u(k-1)
+ G U of :func:`trainctl.controllers.mpc.theory.mpc.prediction_matrices`. This module holds
what every such problem needs, whatever the model:

- :class:`MoveMaps` — decision vector to input moves (u- or Δu-form), move
  differences, the first move and the shift of the previous plan;
- :func:`input_rows` — constraint rows bounding the moves and their rates;
- :class:`QPBlock` / :func:`build_block` — one QP over some columns of U,
  modelled once as a :class:`~trainctl.controllers.mpc.qp.parametric.ParametricQP`, with its
  parameters gathered from a per-step source vector and, on the fast path,
  composed straight into OSQP's data (the other blocks' moves, when the plan
  is split among several optimisers, enter through the coupling maps Ko, Fo);
- :func:`block_parameters` — the per-step parameters of a list of blocks.

The MPC core (:mod:`trainctl.controllers.mpc.linear`) is one block over the whole plan; the train
MPC (:mod:`.problem`) is one block per optimiser of its strategy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from trainctl.controllers.mpc.qp.fast import QPSolution
from trainctl.controllers.mpc.qp.parametric import PARAMETERS, ParametricQP
from trainctl.exceptions import ModelError

__all__ = ["BlockParameters", "MoveMaps", "ParameterGather", "QPBlock", "block_parameters",
           "build_block",
           "input_rows", "move_maps", "shifted"]

Array = NDArray[np.float64]
Index = NDArray[np.int64]


@dataclass(frozen=True)
class MoveMaps:
    """Maps of the decision vector U of a condensed MPC (moves ordered move by move).

    Parameters
    ----------
    n_inputs, control_horizon : int
        nu inputs, M moves.
    form : {"u", "du"}
        The decision: input moves or their increments.
    L : ndarray
        Decision to input moves, (M·nu, M·nu): identity (u-form) or cumulative
        sums (Δu-form; the moves are then u(k-1) tiled plus L U).
    D : ndarray
        Move differences: (D u)_m = u_m - u_(m-1), with u_(-1) taken as 0.
    first : ndarray
        The rows of L giving the first move, (nu, M·nu), C-contiguous.
    shift : ndarray of int
        Index of the plan shifted by one move (the last move repeated; in the
        Δu-form :func:`shifted` then zeroes it).

    Examples
    --------
    Two inputs over two moves in the u-form: the plan is the moves, and D
    takes the difference of consecutive moves of each input.

    >>> maps = move_maps(2, 2, "u")
    >>> maps.L.tolist() == np.eye(4).tolist(), maps.shift.tolist()
    (True, [2, 3, 2, 3])
    >>> maps.D.astype(int).tolist()
    [[1, 0, 0, 0], [0, 1, 0, 0], [-1, 0, 1, 0], [0, -1, 0, 1]]
    """

    n_inputs: int
    control_horizon: int
    form: str
    L: Array
    D: Array
    first: Array
    shift: Index


def move_maps(n_inputs: int, control_horizon: int, form: str) -> MoveMaps:
    """The :class:`MoveMaps` of nu inputs over M moves in the u- or Δu-form.

    Parameters
    ----------
    n_inputs : int
        nu, the number of inputs.
    control_horizon : int
        M, the number of moves.
    form : {"u", "du"}
        Whether the plan holds the inputs or their increments.

    Returns
    -------
    MoveMaps
        The maps from the plan to the inputs and the shift of a plan.

    Examples
    --------
    >>> maps = move_maps(1, 3, "du")
    >>> maps.L.tolist(), maps.shift.tolist()
    ([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 1.0, 1.0]], [1, 2, 2])
    """
    n, M = n_inputs, control_horizon
    L = np.asarray(np.eye(M * n) if form == "u"
                   else np.kron(np.tril(np.ones((M, M))), np.eye(n)), dtype=np.float64)
    D = np.asarray(np.kron(np.eye(M) - np.eye(M, k=-1), np.eye(n)), dtype=np.float64)
    last = np.arange((M - 1) * n, M * n)
    shift = np.concatenate([np.arange(n, M * n), last])
    return MoveMaps(n_inputs=n, control_horizon=M, form=form, L=L, D=D,
                    first=np.ascontiguousarray(L[:n]), shift=shift)


def shifted(maps: MoveMaps, plan: Array | None) -> Array:
    """The previous plan shifted by one move (u-form: last move repeated; Δu-form: zero).

    None (no previous plan) gives zeros.

    Parameters
    ----------
    maps : MoveMaps
        The plan's maps (:func:`move_maps`).
    plan : ndarray or None
        The previous plan, or None.

    Returns
    -------
    ndarray
        The starting plan of the next sample.

    Examples
    --------
    >>> shifted(move_maps(2, 2, "u"), np.array([1.0, 2.0, 3.0, 4.0])).tolist()  # last repeated
    [3.0, 4.0, 3.0, 4.0]
    >>> shifted(move_maps(1, 3, "du"), np.array([1.0, 2.0, 3.0])).tolist()  # last increment 0
    [2.0, 3.0, 0.0]
    >>> shifted(move_maps(1, 3, "du"), None).tolist()
    [0.0, 0.0, 0.0]
    """
    n, M = maps.n_inputs, maps.control_horizon
    if plan is None:
        return np.zeros(M * n)
    out = plan[maps.shift]
    if maps.form == "du":
        out[(M - 1) * n:] = 0.0
    return out


def input_rows(maps: MoveMaps, cols: Index, *, bounds: bool, rate: bool) -> Array:
    """Rows of [input moves; move rates] restricted to the columns ``cols`` of U.

    Parameters
    ----------
    maps : MoveMaps
        The decision's maps.
    cols : ndarray of int
        The block's columns of U (rows and columns are both restricted: L and
        D are block diagonal by input).
    bounds, rate : bool
        Include the move rows (L) and the rate rows (D L).

    Returns
    -------
    ndarray
        The stacked rows, (0, cols.size) when neither is asked for.

    Examples
    --------
    The first input's columns (0 and 2) of a u-form plan of two inputs over
    two moves: its moves u_0, u_1, then its rates u_0 - 0 and u_1 - u_0.

    >>> maps = move_maps(2, 2, "u")
    >>> input_rows(maps, np.array([0, 2]), bounds=True, rate=True).tolist()
    [[1.0, 0.0], [0.0, 1.0], [1.0, 0.0], [-1.0, 1.0]]
    >>> input_rows(maps, np.array([0, 2]), bounds=False, rate=False).shape
    (0, 2)
    """
    rows = []
    if bounds:
        rows.append(maps.L[np.ix_(cols, cols)])
    if rate:
        rows.append((maps.D @ maps.L)[np.ix_(cols, cols)])
    return np.vstack(rows) if rows else np.zeros((0, cols.size))


@dataclass(frozen=True)
class BlockParameters:
    """One block's QP parameters for one step (at zero moves of the other blocks).

    Parameters
    ----------
    data : ndarray or None
        Fast path: OSQP's stacked data.
    values : dict of str to ndarray or None
        Otherwise: the vectors g, lb, ub, hl, hu.

    Examples
    --------
    >>> prep = BlockParameters(values={"g": np.array([-2.0, 1.0])})
    >>> prep.data is None, prep.values["g"].tolist()
    (True, [-2.0, 1.0])
    """

    data: Array | None = None
    values: dict[str, Array] | None = None


@dataclass(frozen=True)
class QPBlock:
    """One optimiser of a condensed MPC: the inputs it decides for, its QP and maps.

    With e the free response (minus the reference) of the cost rows, the
    block's QP vectors are g = Kc e + Ko U and, for its soft rows,
    hl/hu = (bounds) - Fo U, U the whole plan (Ko, Fo have the block's own
    columns zeroed; None when the block is the only optimiser). Every step the
    parameter vectors of all blocks at U = 0 are stacked in one source vector;
    ``params`` locates the block's g, lb, ub, hl and hu in it. The fast path
    folds all of it into the solver data: data = offset + J·clip(source[gather])
    + Jo U. J is usually a scaled selection (at most one non-zero per row:
    every solver datum comes from one parameter); it is then stored as
    ``pick`` and ``scale``, with J·clip(source[gather]) =
    scale·clip(source)[pick], the same numbers without the dense product.

    Parameters
    ----------
    inputs : tuple of int
        The inputs (coaches) the block decides for.
    cols : ndarray of int
        Their columns in the decision vector.
    Kc : ndarray
        Map from the free response e to g.
    Ko : ndarray or None
        Kc G with the block's own columns zeroed: the other moves into g.
    Fo : ndarray or None
        The soft rows of the plan, own columns zeroed.
    Jo : ndarray or None
        Fast path: the solver data's sensitivity to U.
    qp : ParametricQP
        The block's QP.
    params : dict
        Positions of g, lb, ub, hl and hu in the source vector.
    gather : ndarray of int
        The QP's parameters (its map's columns) in the source vector.
    J : ndarray or None
        Fast path: the data's sensitivity to those parameters.
    offset : ndarray or None
        Fast path: the data at zero parameters.
    pick : ndarray of int or None
        Fast path with J a scaled selection: the source entry of each datum.
    scale : ndarray or None
        The factor of each picked entry (0 for constant data).
    work : (ndarray, ndarray) or None
        Fast path with Jo: the buffers :meth:`solve` composes the solver's data
        and Jo U in (the data buffer may be the solver's own).

    Examples
    --------
    A single block deciding two inputs, with g, lb and ub taken from a
    6-entry source vector. Each OSQP datum comes from one source entry, so
    the fast path stores a scaled selection (the lower bounds enter as -z <=
    -lb, hence the factor -1):

    >>> from trainctl.controllers.mpc.qp.parametric import ParametricQP
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), name="demo")
    >>> params = {"g": np.arange(2), "lb": np.arange(2, 4), "ub": np.arange(4, 6),
    ...           "hl": np.arange(0), "hu": np.arange(0)}
    >>> block = build_block(qp, inputs=(0, 1), cols=np.arange(2), Kc=np.eye(2), params=params)
    >>> block.pick.tolist(), block.scale.tolist()
    ([0, 1, 2, 3, 4, 5], [1.0, 1.0, -1.0, -1.0, 1.0, 1.0])
    """

    inputs: tuple[int, ...]          # the inputs (coaches) it decides for
    cols: Index                      # its columns in the decision vector
    Kc: Array                        # maps the free response e to g
    Ko: Array | None                 # Kc G (own columns zeroed): other moves into g
    Fo: Array | None                 # soft rows of the plan (own columns zeroed)
    Jo: Array | None                 # fast path: data sensitivity to U
    qp: ParametricQP
    params: dict[str, Index]         # positions of g, lb, ub, hl, hu in the source vector
    gather: Index                    # the QP's parameters (its map's columns) in the source
    J: Array | None                  # fast path: data sensitivity to those parameters
    offset: Array | None             # fast path: data at zero parameters
    pick: Index | None               # fast path, J a scaled selection: source entry of each datum
    scale: Array | None              # ... and its factor (0 for constant data)
    work: tuple[Array, Array] | None = None  # fast path with Jo: solve's data and Jo U buffers

    def solve(self, prep: BlockParameters, U: Array | None, path: str) -> QPSolution:
        """Solve the block's QP with the other blocks' moves U (None: zero).

        Parameters
        ----------
        prep : BlockParameters
            The block's parameters of this step at U = 0 (:func:`block_parameters`).
        U : ndarray or None
            The whole plan (decision vector); the block's own columns do not
            enter (Ko, Fo have them zeroed). None: zero, as for a single
            optimiser.
        path : {"fast", "cvxpy"}
            Solve path of :meth:`ParametricQP.solve` when ``prep`` holds the
            vectors; unused when it holds the composed data.

        Returns
        -------
        QPSolution
            The block's decisions (its columns of U), slacks, status,
            iterations and solve time [s].
        """
        if prep.data is not None:
            if U is None:
                return self.qp.solve_data(prep.data)
            assert self.Jo is not None and self.work is not None
            # prep.data + Jo @ U composed in the block's buffer (the same two operations;
            # the data handed to the solver are rewritten by the block's next solve)
            data, coupling = self.work
            np.matmul(self.Jo, U, out=coupling)
            return self.qp.solve_data(np.add(prep.data, coupling, out=data))
        values = prep.values
        assert values is not None
        if U is None:
            return self.qp.solve(values["g"], values["lb"], values["ub"], values["hl"],
                                 values["hu"], path=path)
        assert self.Ko is not None and self.Fo is not None
        shift = self.Fo @ U
        return self.qp.solve(values["g"] + self.Ko @ U, values["lb"], values["ub"],
                             values["hl"] - shift, values["hu"] - shift, path=path)


def build_block(qp: ParametricQP, *, inputs: tuple[int, ...], cols: Index, Kc: Array,
                params: dict[str, Index], Ko: Array | None = None,
                Fo: Array | None = None) -> QPBlock:
    """A :class:`QPBlock` around ``qp``, with its fast-path data maps when ``qp`` has them.

    Parameters
    ----------
    qp : ParametricQP
        The block's QP.
    inputs : tuple of int
        The inputs the block decides for.
    cols : ndarray of int
        Their columns of the decision vector.
    Kc : ndarray
        Map from the free response to g.
    params : dict of str to ndarray of int
        Positions of the QP's g, lb, ub, hl, hu in the per-step source vector.
    Ko, Fo : ndarray or None
        Coupling to the other blocks' moves (None for a single optimiser).

    Returns
    -------
    QPBlock
        The block.

    Examples
    --------
    Minimise ½‖z‖² + gᵀz with g = (-2, 1) in the box -0.5 <= z <= 0.5: the
    unconstrained optimum -g = (2, -1) is clipped to (0.5, -0.5).

    >>> from trainctl.controllers.mpc.qp.parametric import ParametricQP
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), name="demo")
    >>> params = {"g": np.arange(2), "lb": np.arange(2, 4), "ub": np.arange(4, 6),
    ...           "hl": np.arange(0), "hu": np.arange(0)}
    >>> block = build_block(qp, inputs=(0, 1), cols=np.arange(2), Kc=np.eye(2), params=params)
    >>> src = np.array([-2.0, 1.0, -0.5, -0.5, 0.5, 0.5])  # g, lb, ub
    >>> [prep] = block_parameters([block], src, fast=True)
    >>> block.solve(prep, None, "fast").z.round(6).tolist()
    [0.5, -0.5]
    """
    # The map's columns are the QP's non-empty parameters in this order (ParametricQP).
    gather = np.concatenate([params[key] for key in PARAMETERS if params[key].size])
    Jo = J = offset = pick = scale = None
    if qp.has_fast_path:
        offset, blocks = qp.data_map()
        if Ko is not None and Fo is not None:
            Jo = blocks["g"] @ Ko - (blocks["hl"] + blocks["hu"]) @ Fo
        J = np.hstack([blocks[key] for key in PARAMETERS if blocks[key].size])
        if J.shape[1] != gather.size:
            raise ModelError(f"{qp.name}: the QP's parameters do not match the blocks' "
                             "(internal error).")
        nonzero = J != 0
        if J.shape[1] and nonzero.sum(axis=1).max() <= 1:
            column = nonzero.argmax(axis=1)  # 0 for rows without a parameter (scale 0)
            pick, scale = gather[column], J[np.arange(J.shape[0]), column]
            J = None
    work = None
    if Jo is not None:  # [data; coupling]: the data in the dense solver's own buffer if any
        dense = qp.dense_path
        work = (dense.data_buffer if dense is not None else np.empty(Jo.shape[0]),
                np.empty(Jo.shape[0]))
    return QPBlock(inputs=inputs, cols=cols, Kc=Kc, Ko=Ko, Fo=Fo, Jo=Jo, qp=qp, params=params,
                   gather=gather, J=J, offset=offset, pick=pick, scale=scale, work=work)


class ParameterGather:
    """:func:`block_parameters` of a fixed list of blocks, in preallocated arrays.

    On the fast path with every block's map a scaled selection (``pick``,
    ``scale``), all blocks' data are composed by three numpy calls into one
    buffer, ``scale·src[pick] + offset`` elementwise as :func:`block_parameters`
    computes it block by block (the same numbers), and the same
    :class:`BlockParameters` (views of the buffer) are returned every step:
    their data are rewritten by the next call. Otherwise it calls
    :func:`block_parameters`.

    Parameters
    ----------
    blocks : list of QPBlock
        The blocks, in the order of the parameters returned.
    fast : bool
        Compose the solver data (every block has the fast path).

    Examples
    --------
    >>> from trainctl.controllers.mpc.qp.parametric import ParametricQP
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), name="demo")
    >>> params = {"g": np.arange(2), "lb": np.arange(2, 4), "ub": np.arange(4, 6),
    ...           "hl": np.arange(0), "hu": np.arange(0)}
    >>> block = build_block(qp, inputs=(0, 1), cols=np.arange(2), Kc=np.eye(2), params=params)
    >>> gather = ParameterGather([block], fast=True)
    >>> src = np.array([-2.0, 1.0, -0.5, -0.5, 0.5, 0.5])  # g, lb, ub
    >>> [prep] = gather(src)
    >>> prep.data.tolist() == block_parameters([block], src, fast=True)[0].data.tolist()
    True
    """

    def __init__(self, blocks: list[QPBlock], *, fast: bool) -> None:
        self.blocks, self.fast = blocks, fast
        self.stacked = fast and all(b.pick is not None and b.scale is not None
                                    and b.offset is not None for b in blocks)
        if not self.stacked:
            return
        picks = [b.pick for b in blocks if b.pick is not None]
        self._pick = np.concatenate(picks) if picks else np.zeros(0, dtype=np.int64)
        self._scale = np.concatenate([b.scale for b in blocks if b.scale is not None] or
                                     [np.zeros(0)])
        self._offset = np.concatenate([b.offset for b in blocks if b.offset is not None] or
                                      [np.zeros(0)])
        self._data = np.empty(self._pick.size)
        ends = np.cumsum([p.size for p in picks])
        self._params = [BlockParameters(data=self._data[end - p.size:end])
                        for p, end in zip(picks, ends, strict=True)]

    def __call__(self, src: Array) -> list[BlockParameters]:
        """Every block's parameters from the source vector (clipped to ±1e20 in place on the
        fast path), as :func:`block_parameters` gives them."""
        if not self.stacked:
            return block_parameters(self.blocks, src, self.fast)
        np.maximum(src, -1e20, out=src)
        np.minimum(src, 1e20, out=src)
        data = self._data
        np.take(src, self._pick, out=data)
        np.multiply(data, self._scale, out=data)
        np.add(data, self._offset, out=data)
        return self._params


def block_parameters(blocks: list[QPBlock], src: Array, fast: bool) -> list[BlockParameters]:
    """Every block's parameters for one step from the stacked source vector.

    Parameters
    ----------
    blocks : list of QPBlock
        The blocks.
    src : ndarray
        The source vector (clipped to ±1e20 in place on the fast path).
    fast : bool
        Compose the solver data (every block has the fast path) instead of the vectors.

    Returns
    -------
    list of BlockParameters
        One per block.

    Examples
    --------
    The block of :func:`build_block`: without the fast path the vectors are
    picked from the source; with it, OSQP's data [q; h] are composed, the
    lower bounds negated (-z <= -lb).

    >>> from trainctl.controllers.mpc.qp.parametric import ParametricQP
    >>> qp = ParametricQP(np.eye(2), np.eye(2), np.zeros((0, 2)), name="demo")
    >>> params = {"g": np.arange(2), "lb": np.arange(2, 4), "ub": np.arange(4, 6),
    ...           "hl": np.arange(0), "hu": np.arange(0)}
    >>> block = build_block(qp, inputs=(0, 1), cols=np.arange(2), Kc=np.eye(2), params=params)
    >>> src = np.array([-2.0, 1.0, -0.5, -0.5, 0.5, 0.5])  # g, lb, ub
    >>> [prep] = block_parameters([block], src, fast=False)
    >>> prep.values["lb"].tolist(), prep.data is None
    ([-0.5, -0.5], True)
    >>> [prep] = block_parameters([block], src, fast=True)
    >>> prep.data.tolist()
    [-2.0, 1.0, 0.5, 0.5, 0.5, 0.5]
    """
    if fast:
        # The map was identified with parameters clipped to ±1e20 (ParametricQP);
        # maximum then minimum is np.clip, without its Python-level overhead.
        np.maximum(src, -1e20, out=src)
        np.minimum(src, 1e20, out=src)
        out = []
        for block in blocks:
            assert block.offset is not None
            if block.pick is not None and block.scale is not None:
                data = src[block.pick]
                data *= block.scale
            else:
                assert block.J is not None
                data = block.J @ src[block.gather]
            data += block.offset
            out.append(BlockParameters(data=data))
        return out
    return [BlockParameters(values={key: src[index] for key, index in block.params.items()})
            for block in blocks]
