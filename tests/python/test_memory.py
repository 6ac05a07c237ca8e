"""10^6 steps from Python keep the process's memory flat: the environments' and controllers' calls allocate nothing
that outlives them (the arrays they return are freed by Python).

What is measured is what the process keeps: bytes that glibc's allocator has handed out and not got back (all arenas,
mmapped blocks included) and the blocks Python's own allocator holds. Resident memory alone also moves with arena
fragmentation under a loaded machine (seen: 0.3 to 4.5 MB over 10^6 steps with the bytes in use flat to 1 kB), so it
is only a loose bound here."""
import ctypes
import os
import re
import sys
import tempfile

import numpy as np

import rmpmarl


def _rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


_libc = ctypes.CDLL(None)
_libc.fopen.restype = ctypes.c_void_p
_libc.fopen.argtypes = [ctypes.c_char_p, ctypes.c_char_p]
_libc.malloc_info.argtypes = [ctypes.c_int, ctypes.c_void_p]
_libc.fclose.argtypes = [ctypes.c_void_p]


def _heap_in_use_mb():
    """Bytes malloc has handed out and not got back: glibc's over every arena, from malloc_info's totals, or
    AddressSanitizer's own count where it replaces malloc (the sanitizer build)."""
    if hasattr(_libc, "__sanitizer_get_current_allocated_bytes"):
        _libc.__sanitizer_get_current_allocated_bytes.restype = ctypes.c_size_t
        return _libc.__sanitizer_get_current_allocated_bytes() / 2**20
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "malloc_info.xml")
        stream = _libc.fopen(path.encode(), b"w")
        assert stream, path
        assert _libc.malloc_info(0, stream) == 0
        _libc.fclose(stream)
        with open(path) as f:
            xml = f.read()
    totals = xml[xml.rfind("</heap>"):]

    def total(pattern):
        match = re.search(pattern, totals)
        assert match, f"malloc_info has no {pattern!r}: {totals}"
        return int(match.group(1))

    free = total(r'<total type="fast" count="\d+" size="(\d+)"') + total(r'<total type="rest" count="\d+" size="(\d+)"')
    mmapped = total(r'<total type="mmap" count="\d+" size="(\d+)"')
    return (total(r'<system type="current" size="(\d+)"') - free + mmapped) / 2**20


class _Kept:
    """What the process keeps between two points: malloc's bytes in use, Python's blocks, resident memory."""

    def __init__(self):
        self.heap, self.blocks, self.rss = _heap_in_use_mb(), sys.getallocatedblocks(), _rss_mb()

    def growth_since(self, before):
        return self.heap - before.heap, self.blocks - before.blocks, self.rss - before.rss


def test_malloc_in_use_counts_a_kept_allocation():
    before = _heap_in_use_mb()
    kept = [ctypes.create_string_buffer(1024) for _ in range(4096)]  # 4 MB through malloc, held
    grown = _heap_in_use_mb() - before
    assert 3.9 < grown < 4.5, grown
    del kept


def test_a_million_env_steps_keep_memory_flat():
    envs = rmpmarl.make_vec_env("pretrain-2link", 64, num_threads=2, seed=0,
                                overrides={"episode": {"max_steps": 50}})  # many autoresets too
    envs.reset(seed=0)
    actions = np.zeros(envs.action_space.shape, np.float32)
    # warm-up: each link-length variant builds its scenario on first use (measured: malloc's bytes in use 18.8 ->
    # 26.84 MB over the first 4e5 steps, then flat to 1 kB over the next 2.5e6). A leak of one 8-byte allocation per
    # env step would keep 32 MB (malloc's smallest chunk) over the measured 1e6 steps; one Python object per step,
    # 1e6 blocks.
    warm_up = 500_000 // envs.num_envs
    batches = 10**6 // envs.num_envs
    for i in range(warm_up + batches):
        if i == warm_up:
            warm = _Kept()
        obs, rewards, terminated, truncated, info = envs.step(actions)
    heap, blocks, rss = _Kept().growth_since(warm)
    steps = batches * envs.num_envs
    assert heap < 0.5, f"malloc's bytes in use grew {heap:.2f} MB over {steps} env steps"
    assert blocks < 1000, f"Python kept {blocks} more blocks after {steps} env steps"
    assert rss < 16.0, f"resident memory grew {rss:.1f} MB over {steps} env steps"


def test_a_million_controller_calls_keep_memory_flat():
    controller = rmpmarl.rmpflow("panda", max_obstacles=2)
    q = np.array([0.0, -0.5, 0.0, -2.0, 0.0, 1.6, 0.8])
    controller.reset(q)
    qd, target = np.zeros(7), np.array([0.4, 0.1, 0.5])
    boxes = np.array([[0.4, 0.3, 0.4, 0.04, 0.04, 0.04]])
    n = 10**6
    for i in range(n):
        controller.accelerations(q, qd, target=target, boxes=boxes)
        if i == n // 10:
            warm = _Kept()
    heap, blocks, rss = _Kept().growth_since(warm)
    calls = f"{0.9 * n:.0f} controller calls"
    assert heap < 0.5, f"malloc's bytes in use grew {heap:.2f} MB over {calls}"
    assert blocks < 1000, f"Python kept {blocks} more blocks after {calls}"
    assert rss < 4.0, f"resident memory grew {rss:.1f} MB over {calls}"
