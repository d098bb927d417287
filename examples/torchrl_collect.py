"""TorchRL over petswarm: ``PettingZooWrapper`` around the fixed-agents env, collected with TorchRL's
``Collector`` and the shipped one-frame MLP policy (``mappo_generalize.npz``; ``learned`` is recurrent,
a memory per robot, which a feed-forward TensorDict actor does not carry) as a TensorDict actor (the ``torchrl`` extra)::

    pip install -e '.[torchrl]'          # torchrl 0.14.1, tensordict 0.14.3 (with torch==2.13.0)
    python examples/torchrl_collect.py --frames 400

What it shows:

- ``FixedAgents`` (petswarm_env/wrappers.py) gives TorchRL what it needs: every possible agent at
  reset and at every step (TorchRL builds its specs from the reset), flat numeric infos with the
  same keys at reset and step, ``state()`` for ``return_state=True`` (a MAPPO critic's input);
- the agents form one group, ``"robot"``: observations ``("robot", "observation")`` of shape
  (robots, the layout's size: 67 for layout 2), actions ``("robot", "action")`` (robots, 3), infos ``("robot", "info", key)``;
- ``done_on_any=False``: the episode ends when every robot is done, which FixedAgents makes one step.
"""

from __future__ import annotations

import argparse

import numpy as np
import torch
from tensordict.nn import TensorDictModule
from torchrl.collectors import Collector
from torchrl.envs import PettingZooWrapper

from petswarm.baselines.learned import feed_forward_policy_path, observation_mapping, read_policy_file
from petswarm.baselines.policy import PolicySpec
from petswarm_env import petswarm_v1
from petswarm_env.wrappers import FixedAgents


def make_env(max_cycles: int = 100, **overrides) -> PettingZooWrapper:
    """petswarm_v1's ParallelEnv behind FixedAgents, as a TorchRL env with the global state."""
    return PettingZooWrapper(env=FixedAgents(petswarm_v1.parallel_env(max_cycles=max_cycles, **overrides)),
                             return_state=True, use_mask=False, done_on_any=False)


class _Select(torch.nn.Module):
    """The env observation's columns the policy file was trained on, in its order
    (petswarm.baselines.learned.observation_mapping: fields matched by name and size)."""

    def __init__(self, index: np.ndarray):
        super().__init__()
        self.register_buffer("index", torch.as_tensor(index, dtype=torch.long))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x.index_select(-1, self.index)


def actor_from_policy_file(path=None) -> TensorDictModule:
    """A TensorDict actor from a petswarm policy file (default: the shipped feed-forward one): the same layers
    as baselines/learned.py's numpy forward, in torch, after the same field mapping onto this env's
    observation (the default config's), with the action clipped to [-1, 1]."""
    meta, layers = read_policy_file(path or feed_forward_policy_path())
    layout = PolicySpec.from_env(petswarm_v1.parallel_env()).layout
    index = observation_mapping([(n, s) for n, s in meta["observation_layout"]], layout)
    act = torch.nn.Tanh if meta["activation"] == "tanh" else torch.nn.ReLU
    modules: list[torch.nn.Module] = [_Select(index)]
    for i, (w, b) in enumerate(layers):
        linear = torch.nn.Linear(w.shape[1], w.shape[0])
        with torch.no_grad():
            linear.weight.copy_(torch.from_numpy(np.asarray(w, np.float32)))
            linear.bias.copy_(torch.from_numpy(np.asarray(b, np.float32)))
        modules += [linear] if i == len(layers) - 1 else [linear, act()]
    net = torch.nn.Sequential(*modules, torch.nn.Hardtanh(-1.0, 1.0))
    return TensorDictModule(net, in_keys=[("robot", "observation")], out_keys=[("robot", "action")])


def collect(frames: int = 400, frames_per_batch: int = 200, max_cycles: int = 100, seed: int = 0) -> dict:
    """Collect ``frames`` env steps with the shipped feed-forward policy; returns what was collected."""
    torch.manual_seed(seed)
    env = make_env(max_cycles)
    env.set_seed(seed)
    collector = Collector(env, policy=actor_from_policy_file(), frames_per_batch=frames_per_batch, total_frames=frames)
    batches = list(collector)
    collector.shutdown()
    env.close()
    last = batches[-1]
    return {
        "frames": sum(b.numel() for b in batches),
        "observation_shape": tuple(last["robot", "observation"].shape),
        "state_shape": tuple(last["state"].shape),
        "episodes_ended": int(sum(int(b["next", "done"].sum()) for b in batches)),
        "mean_reward": float(torch.cat([b["next", "robot", "reward"].flatten() for b in batches]).mean()),
        "batches": batches,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=400)
    parser.add_argument("--max-cycles", type=int, default=100)
    args = parser.parse_args()
    out = collect(args.frames, max_cycles=args.max_cycles)
    out.pop("batches")
    print(out)


if __name__ == "__main__":
    main()
