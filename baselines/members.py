"""A recurrent policy's network as side-by-side members: the step :class:`~petswarm.baselines.learned.RecurrentPolicy` runs.

A policy file of ``recurrent.members: M`` (training/ensemble.py) is one network whose output is the
mean of M students: their first encoder layers stacked, their later layers, GRU gates and hidden head
layers block-diagonal, a last layer that averages. Run as written, a step multiplies matrices that are
nearly all zeros: M times the arithmetic of the M students run one by one (M² times one student's).
:meth:`MemberStack.split` takes the file's matrices apart into the M students' own, stacked on a first
axis, and :meth:`MemberStack.step` runs them as a batch of M small products: the same network, the
same outputs up to the order of float64 sums (tests/unit/test_members.py checks both against the
merged network's products). A plain network is one member.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

Layer = tuple[np.ndarray, np.ndarray]


def _blocks(w: np.ndarray, members: int, cols: list[slice] | None = None) -> np.ndarray | None:
    """Member m's rows (the m-th of ``members`` equal row blocks) and columns (``cols[m]``, or the
    m-th equal column block), stacked (M, rows, cols); None if anything outside those blocks is not zero."""
    rows, width = w.shape[0] // members, w.shape[1] // members
    cols = cols or [slice(m * width, (m + 1) * width) for m in range(members)]
    out, rest = [], np.array(w, dtype=np.float64, copy=True)
    for m in range(members):
        r = slice(m * rows, (m + 1) * rows)
        out.append(np.array(w[r, cols[m]], dtype=np.float64))
        rest[r, cols[m]] = 0.0
    return np.stack(out) if not rest.any() else None


@dataclass(frozen=True)
class MemberStack:
    """The M members' weights, each array with the members first, transposed for ``x @ w``:
    ``encoder`` and ``head`` [(W (M, in, out), b (M, 1, out))], the GRU's ``w_ih`` (M, in, 3n),
    ``w_hh`` (M, n, 3n), ``b_ih``, ``b_hh`` (M, 1, 3n) (gates r, z, n, as torch's ``nn.GRU``), and the
    last layer ``out_w`` (M, k, 3) with its bias ``out_b`` (3,): the sum over members (the 1/M of the
    mean is in the weights)."""

    members: int
    hidden: int  # one member's hidden size
    encoder: list[Layer]
    w_ih: np.ndarray
    w_hh: np.ndarray
    b_ih: np.ndarray
    b_hh: np.ndarray
    head: list[Layer]
    out_w: np.ndarray
    out_b: np.ndarray

    @classmethod
    def split(cls, layers: list[Layer], encoder_layers: int, cell, members: int) -> MemberStack:
        """The members of a merged network (``layers``: encoder then head; ``cell``: a GRUCell), or
        the network as one member when it does not have the block structure of ``members``."""
        if members > 1:
            stack = cls._split(layers, encoder_layers, cell, members)
            if stack is not None:
                return stack
        return cls._split(layers, encoder_layers, cell, 1)

    @classmethod
    def _split(cls, layers: list[Layer], k: int, cell, m: int) -> MemberStack | None:
        n = cell.w_hh.shape[1] // m
        if m > 1 and (k < 1 or len(layers) < k + 2 or cell.w_hh.shape[1] % m or any(w.shape[0] % m for w, _ in layers[:-1])):
            return None  # an ensemble has an encoder and a head (training/ensemble.py)

        def rows(b: np.ndarray) -> np.ndarray:
            return np.asarray(b, dtype=np.float64).reshape(m, 1, -1)

        def t(ws: np.ndarray) -> np.ndarray:
            return ws.transpose(0, 2, 1).copy()

        encoder = []
        for j, (w, b) in enumerate(layers[:k]):  # the first layer reads the one observation: its columns are everyone's
            ws = _blocks(w, m, [slice(None)] * m if j == 0 else None)
            if ws is None:
                return None
            encoder.append((t(ws), rows(b)))
        gates = []
        for w in (cell.w_ih, cell.w_hh):  # each gate block-diagonal over the members (training/ensemble.py)
            per_gate = [_blocks(w[g * m * n:(g + 1) * m * n], m) for g in range(3)]
            if any(p is None for p in per_gate):
                return None
            gates.append(t(np.concatenate(per_gate, axis=1)))
        biases = [np.asarray(b, dtype=np.float64).reshape(3, m, n).transpose(1, 0, 2).reshape(m, 1, 3 * n)
                  for b in (cell.b_ih, cell.b_hh)]
        head = []
        for j, (w, b) in enumerate(layers[k:-1]):  # the first reads [its encoding, its hidden state]
            if m == 1:  # also with no encoder layer (k = 0), where the head reads [observation, hidden state]
                ws = np.asarray(w, dtype=np.float64)[None]
            elif j == 0:
                feed = layers[k - 1][0].shape[0] // m
                enc, mem = _blocks(w[:, :m * feed], m), _blocks(w[:, m * feed:], m)
                ws = None if enc is None or mem is None else np.concatenate([enc, mem], axis=2)
            else:
                ws = _blocks(w, m)
            if ws is None:
                return None
            head.append((t(ws), rows(b)))
        w, b = layers[-1]
        width = w.shape[1] // m
        out_w = np.stack([np.asarray(w[:, i * width:(i + 1) * width], np.float64).T for i in range(m)])
        return cls(m, n, encoder, *gates, *biases, head, out_w, np.asarray(b, dtype=np.float64))

    def step(self, x: np.ndarray, h: np.ndarray, act: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """Observations ``x`` (batch, in) and hidden states ``h`` (batch, M·n, the merged network's
        order) -> (the mean output (batch, 3), the next hidden states (batch, M·n))."""
        m, n = self.members, self.hidden
        y = x[None]
        for w, b in self.encoder:
            y = act(y @ w + b)  # (M, batch, out)
        hs = h.reshape(len(h), m, n).transpose(1, 0, 2)
        gi = y @ self.w_ih + self.b_ih
        gh = hs @ self.w_hh + self.b_hh
        r = _sigmoid(gi[..., :n] + gh[..., :n])
        z = _sigmoid(gi[..., n:2 * n] + gh[..., n:2 * n])
        c = np.tanh(gi[..., 2 * n:] + r * gh[..., 2 * n:])
        hs = (1.0 - z) * c + z * hs
        y = np.concatenate([y, hs], axis=-1)
        for w, b in self.head:
            y = act(y @ w + b)
        out = (y @ self.out_w).sum(axis=0) + self.out_b
        return out, hs.transpose(1, 0, 2).reshape(len(h), m * n)


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * x))  # = 1 / (1 + exp(-x)), without overflow (as GRUCell's)
