"""Shared pieces of the benchmark scripts: machine header, timing with medians, optional plots."""
import os
import platform
import statistics
import time

import cgbound as cg


def cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def load_average():
    try:
        return "%.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "unknown"


def vector_build():
    """Which build of the separable Gaussian runs: 8-wide (AVX-512) or 4-wide (AVX2/baseline)."""
    from cgbound import _engine
    return "AVX-512 (8 doubles)" if _engine.wide_vectors() else "AVX2/baseline (4 doubles)"


def header(threads=None, extra=""):
    """The machine line printed above every table."""
    t = threads if threads is not None else cg.get_num_threads()
    return (f"# CPU: {cpu_model()}; cores: {os.cpu_count()}; threads: {t}; OpenMP build: {cg.have_openmp()}; "
            f"vectors: {vector_build()}; load average: {load_average()}; cgbound {cg.__version__}"
            + (f"; {extra}" if extra else ""))


def timed(fn, repeat, warmup=0, cpu=False):
    """Median and minimum wall time of fn() over `repeat` runs (after `warmup` untimed runs).

    cpu=True also returns the median CPU time of the process (all threads): on a shared, busy machine
    wall times of a multi-threaded run say more about the neighbours than about the code, while the
    CPU time of a one-thread run stays close to its wall time on a quiet machine."""
    for _ in range(warmup):
        fn()
    times, cpus = [], []
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - start)
        cpus.append(time.process_time() - start_cpu)
    if cpu:
        return statistics.median(times), min(times), statistics.median(cpus)
    return statistics.median(times), min(times)


def thread_list(text):
    return [int(t) for t in text.split(",") if t]


def save_plot(path, title, xlabel, ylabel, series, logx=False, logy=False):
    """series: {label: (x values, y values)}; matplotlib is imported only when a plot is asked for."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for label, (x, y) in series.items():
        ax.plot(x, y, "o-", label=label)
    ax.set_title(title, fontsize=10)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if logx:
        ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    from cgbound.plot import save_figure
    save_figure(fig, path)  # the format of the extension (PNG, PDF, SVG), atomically
    plt.close(fig)
    print(f"# plot written to {path}")
