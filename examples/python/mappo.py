#!/usr/bin/env python3
"""MAPPO in PyTorch on rmpmarl's vectorised environments, in one file.

One agent per joint: a shared actor maps each joint's local observation to its hybrid action (an RMP option, four RMP
parameters, a termination flag); a centralised critic values the global state. The update is PPO's clipped surrogate
over the joints' joint log-probabilities, as the C++ trainer (`rmpmarl train`) does it with the same defaults
(configs/train/mappo-nopretrain-reach-avoid.yaml): 3 x 128 ReLU networks, 16 envs x 128 steps per update, 5 epochs x
4 minibatches, clip 0.2, value clip 0.2, GAE(0.99, 0.95), Adam 3e-4 decayed linearly, running normalisation of
observations, states and returns.

    /usr/bin/python3 examples/python/mappo.py --updates 300 --seed 1 --out runs/python-mappo-seed1

Writes metrics.csv (one row per update) and, with --eval-episodes, the deterministic policy's success and tracking
on held-out episodes before and after training. Uses Debian's python3-torch (one thread).
"""
import argparse
import csv
import math
import os
import sys
import time

import numpy as np
import torch
from torch import nn

if os.environ.get("RMPMARL_PYTHONPATH"):  # the build tree, when not installed or on PYTHONPATH
    sys.path.insert(0, os.environ["RMPMARL_PYTHONPATH"])
import rmpmarl  # noqa: E402


class RunningMeanStd:
    """running mean and variance (Chan et al.'s parallel update) of the last axis."""

    def __init__(self, size):
        self.mean, self.var, self.count = torch.zeros(size), torch.ones(size), 1e-4

    def update(self, x):
        x = x.reshape(-1, self.mean.numel())
        n, mean, var = x.shape[0], x.mean(0), x.var(0, unbiased=False)
        delta, total = mean - self.mean, self.count + n
        self.var = (self.var * self.count + var * n + delta**2 * self.count * n / total) / total
        self.mean, self.count = self.mean + delta * n / total, total

    def normalize(self, x, clip=10.0):
        return ((x - self.mean) / torch.sqrt(self.var + 1e-8)).clamp(-clip, clip)


def mlp(sizes, out_gain):
    layers = []
    for i in range(len(sizes) - 1):
        layer = nn.Linear(sizes[i], sizes[i + 1])
        last = i == len(sizes) - 2
        nn.init.orthogonal_(layer.weight, out_gain if last else math.sqrt(2))
        nn.init.zeros_(layer.bias)
        layers += [layer] if last else [layer, nn.ReLU()]
    return nn.Sequential(*layers)


class Actor(nn.Module):
    """the shared per-joint actor: head = [option logits | continuous means | termination logit]."""

    def __init__(self, obs_dim, layout, hidden=(128, 128, 128)):
        super().__init__()
        self.k, self.c, self.term = layout["num_options"], layout["num_continuous"], layout["has_termination"]
        self.net = mlp([obs_dim, *hidden, self.k + self.c + int(self.term)], 0.01)
        self.log_std = nn.Parameter(torch.full((self.c,), -0.5))

    def dists(self, obs):
        h = self.net(obs)
        option = torch.distributions.Categorical(logits=h[..., :self.k]) if self.k else None
        cont = torch.distributions.Normal(h[..., self.k:self.k + self.c], self.log_std.exp())
        term = torch.distributions.Bernoulli(logits=h[..., -1]) if self.term else None
        return option, cont, term

    def log_prob(self, obs, actions, option_mask):
        """the joint log-probability and entropies; the option's part only where it started a new option."""
        option, cont, term = self.dists(obs)
        lp = cont.log_prob(actions[..., self.k > 0:(self.k > 0) + self.c]).sum(-1)
        ent = {"continuous": cont.entropy().sum(-1)}
        if option is not None:
            lp = lp + option_mask * option.log_prob(actions[..., 0].long())
            ent["option"] = option.entropy()
        if term is not None:
            lp = lp + term.log_prob(actions[..., -1])
            ent["termination"] = term.entropy()
        return lp, ent

    def act(self, obs, deterministic=False):
        option, cont, term = self.dists(obs)
        parts = []
        if option is not None:
            parts.append((option.probs.argmax(-1) if deterministic else option.sample()).float()[..., None])
        parts.append(cont.mean if deterministic else cont.sample())
        if term is not None:
            parts.append(((term.logits > 0).float() if deterministic else term.sample())[..., None])
        return torch.cat(parts, -1)


def evaluate(act, args, seed):
    """success rate and mean tracking error [mm] of deterministic actions act(obs) on held-out episodes."""
    envs = rmpmarl.make_vec_env(args.task, args.eval_envs, interface=args.interface, overrides=args.overrides,
                                seed=seed)
    obs, _ = envs.reset(seed=seed)
    done, success, tracking = 0, [], []
    while done < args.eval_episodes:
        obs, _, _, _, info = envs.step(act(obs))
        if "metrics" in info:
            ended = info["_metrics"]
            success += list(info["metrics"]["success"][ended])
            tracking += list(1000.0 * info["metrics"]["tracking_error"][ended])
            done += int(ended.sum())
    return float(np.mean(success[:args.eval_episodes])), float(np.mean(tracking[:args.eval_episodes]))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--task", default="reach-avoid")
    p.add_argument("--interface", default="per-joint-rmp")
    p.add_argument("--updates", type=int, default=300)
    p.add_argument("--envs", type=int, default=16)
    p.add_argument("--steps", type=int, default=128, help="rollout steps per env per update")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--lr", type=float, default=3e-4)
    p.add_argument("--out", default="")
    p.add_argument("--eval-episodes", type=int, default=0, help="held-out episodes before and after training")
    p.add_argument("--eval-envs", type=int, default=8)
    p.add_argument("--eval-seed", type=int, default=20231001)
    p.add_argument("--overrides", default=None, help="task overrides (YAML/JSON text), e.g. observation slots")
    p.add_argument("--compare", nargs="*", default=[], help="controller files (.rmpp, e.g. the C++ trainer's) "
                   "evaluated on the same held-out episodes")
    args = p.parse_args()
    torch.manual_seed(args.seed)
    torch.set_num_threads(1)

    envs = rmpmarl.make_vec_env(args.task, args.envs, interface=args.interface, overrides=args.overrides,
                                seed=1000 * args.seed)
    N, A, D = envs.num_envs, envs.num_agents, envs.task_spec["local_obs_dim"]
    S, T = envs.task_spec["global_state_dim"], args.steps
    actor = Actor(D, envs.action_layout)
    critic = mlp([S, 128, 128, 128, 1], 1.0)
    opt_actor = torch.optim.Adam(actor.parameters(), lr=args.lr, eps=1e-5)
    opt_critic = torch.optim.Adam(critic.parameters(), lr=args.lr, eps=1e-5)
    obs_norm, state_norm, ret_norm = RunningMeanStd(D), RunningMeanStd(S), RunningMeanStd(1)
    gamma, lam, clip = 0.99, 0.95, 0.2

    def act(obs):
        with torch.no_grad():
            return actor.act(obs_norm.normalize(torch.from_numpy(obs)), deterministic=True).numpy().astype(np.float32)

    before = evaluate(act, args, args.eval_seed) if args.eval_episodes else None
    writer = None
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        out_file = open(os.path.join(args.out, "metrics.csv"), "w", newline="")
        writer = csv.writer(out_file)
        writer.writerow(["update", "env_steps", "success_rate", "tracking_error_mm", "mean_return", "seconds"])
    obs, info = envs.reset(seed=1000 * args.seed)
    state = info["state"]
    resetting = np.zeros(N, bool)  # next-step autoreset: this step only resets these envs
    window, start = [], time.perf_counter()
    for update in range(1, args.updates + 1):
        for group in (opt_actor, opt_critic):
            group.param_groups[0]["lr"] = args.lr * (1.0 - (update - 1) / args.updates)
        buf = {k: [] for k in ["obs", "state", "act", "value", "reward", "valid", "opt", "end", "trunc", "boot"]}
        for t in range(T):
            o, s = torch.from_numpy(obs), torch.from_numpy(state)
            obs_norm.update(o), state_norm.update(s)
            with torch.no_grad():
                o_n, s_n = obs_norm.normalize(o), state_norm.normalize(s)
                a = actor.act(o_n)
                value = critic(s_n).squeeze(-1)
            obs, reward, terminated, truncated, info = envs.step(a.numpy().astype(np.float32))
            state = info["state"]
            ended = terminated | truncated
            with torch.no_grad():  # a truncated episode's last state is bootstrapped
                boot = critic(state_norm.normalize(torch.from_numpy(state))).squeeze(-1)
            for k, v in [("obs", o_n), ("state", s_n), ("act", a), ("value", value), ("boot", boot),
                         ("trunc", torch.from_numpy(truncated & ~terminated).float()),
                         ("reward", torch.from_numpy(reward)), ("valid", torch.from_numpy(~resetting)),
                         ("opt", torch.from_numpy(info["option_started"])), ("end", torch.from_numpy(ended))]:
                buf[k].append(v)
            if "metrics" in info:
                e = info["metrics"]
                for k in np.flatnonzero(info["_metrics"]):
                    window.append((e["success"][k], 1000.0 * e["tracking_error"][k], e["return"][k]))
            resetting = ended
        with torch.no_grad():
            last_value = critic(state_norm.normalize(torch.from_numpy(state))).squeeze(-1)
        b = {k: torch.stack(v) for k, v in buf.items()}
        with torch.no_grad():
            lp_old, _ = actor.log_prob(b["obs"], b["act"], b["opt"])
        # GAE over valid steps (values in normalised-return units, denormalised here)
        sd = torch.sqrt(ret_norm.var + 1e-8)
        values = b["value"] * sd + ret_norm.mean
        boot = b["trunc"] * (b["boot"] * sd + ret_norm.mean)  # 0 after a termination
        adv = torch.zeros(T, N)
        gae, next_value = torch.zeros(N), last_value * sd + ret_norm.mean
        for t in reversed(range(T)):
            end, valid = b["end"][t].float(), b["valid"][t].float()
            target_next = torch.where(b["end"][t], boot[t], next_value)
            delta = b["reward"][t] + gamma * target_next - values[t]
            gae = valid * (delta + gamma * lam * (1.0 - end) * gae)
            adv[t], next_value = gae, values[t]
        returns = adv + values
        ret_norm.update(returns[b["valid"]].reshape(-1, 1))
        returns_n = (returns - ret_norm.mean) / torch.sqrt(ret_norm.var + 1e-8)
        valid = b["valid"].reshape(-1)
        flat = {k: v.reshape(T * N, *v.shape[2:])[valid] for k, v in b.items()}
        adv_f, ret_f, lp_f = adv.reshape(-1)[valid], returns_n.reshape(-1)[valid], lp_old.reshape(T * N, A)[valid]
        adv_f = (adv_f - adv_f.mean()) / (adv_f.std() + 1e-8)
        n = adv_f.shape[0]
        for _ in range(5):
            for idx in torch.randperm(n).chunk(4):
                lp, ent = actor.log_prob(flat["obs"][idx], flat["act"][idx], flat["opt"][idx])
                ratio = torch.exp((lp - lp_f[idx]).sum(-1))  # the joints' joint action
                surrogate = torch.min(ratio * adv_f[idx], ratio.clamp(1 - clip, 1 + clip) * adv_f[idx])
                entropy = 0.01 * ent.get("option", torch.zeros(1)).mean() + 0.01 * ent.get(
                    "termination", torch.zeros(1)).mean()
                opt_actor.zero_grad()
                (-(surrogate.mean() + entropy)).backward()
                nn.utils.clip_grad_norm_(actor.parameters(), 0.5)
                opt_actor.step()
                v = critic(flat["state"][idx]).squeeze(-1)
                v_old = flat["value"][idx]
                v_clipped = v_old + (v - v_old).clamp(-clip, clip)
                value_loss = 0.5 * torch.max((v - ret_f[idx]) ** 2, (v_clipped - ret_f[idx]) ** 2).mean()
                opt_critic.zero_grad()
                value_loss.backward()
                nn.utils.clip_grad_norm_(critic.parameters(), 0.5)
                opt_critic.step()
        window = window[-100:]
        stats = np.mean(window, axis=0) if window else [math.nan] * 3
        seconds = time.perf_counter() - start
        if writer:
            writer.writerow([update, update * T * N, stats[0], stats[1], stats[2], f"{seconds:.2f}"])
            out_file.flush()
        if update % 10 == 0 or update == args.updates:
            if window:
                print(f"update {update}/{args.updates}: success {stats[0]:.2f}, tracking {stats[1]:.1f} mm, "
                      f"return {stats[2]:.0f}, {seconds:.0f} s", flush=True)
            else:  # no episode has ended yet (an episode lasts longer than the updates so far)
                print(f"update {update}/{args.updates}: success –, tracking –, return – (no episode ended yet), "
                      f"{seconds:.0f} s", flush=True)
    if args.eval_episodes:
        rows = [("untrained", *before), ("trained", *evaluate(act, args, args.eval_seed))]
        for path in args.compare:
            policy = rmpmarl.Policy(path)
            rows.append((path, *evaluate(lambda o: policy.act(o.reshape(-1, policy.obs_dim)).reshape(
                o.shape[0], o.shape[1], -1), args, args.eval_seed)))
        print(f"held-out: {args.eval_episodes} episodes, evaluation seed {args.eval_seed}, deterministic actions")
        for name, success, tracking in rows:
            print(f"  {name}: success {success:.3f}, tracking {tracking:.1f} mm")
        if args.out:
            with open(os.path.join(args.out, "evaluation.csv"), "w") as f:
                f.write("policy,success_rate,tracking_error_mm\n")
                for name, success, tracking in rows:
                    f.write(f"{name},{success},{tracking}\n")


if __name__ == "__main__":
    main()
