"""Build the C core ``cgbound._core`` from csrc/ (plain C11 plus one binding file).

OpenMP is detected by compiling a tiny test program; without it the core is
built serial. Set CGBOUND_NO_OPENMP=1 to force a serial build, and
CGBOUND_SANITIZE=1 for an AddressSanitizer + UndefinedBehaviorSanitizer build.
"""
import glob
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile

import numpy
from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

# the binding and the core (every csrc/cg_*.c)
HERE = os.path.dirname(os.path.abspath(__file__))
SOURCES = ["csrc/_coremodule.c"] + sorted(os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "csrc", "cg_*.c")))


def compiler_accepts(flags):
    """Whether the C compiler builds and links an OpenMP program with these flags."""
    cc = os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc"
    cc = cc.split()
    tmp = tempfile.mkdtemp()
    try:
        src = os.path.join(tmp, "t.c")
        with open(src, "w") as f:
            f.write("#include <omp.h>\nint main(void){return omp_get_max_threads() > 0 ? 0 : 1;}\n")
        cmd = cc + flags + [src, "-o", os.path.join(tmp, "t")]
        return subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode == 0
    except OSError:
        return False
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


class BuildExt(build_ext):
    def build_extensions(self):
        compile_args = ["-std=c11", "-O3", "-fno-math-errno", "-fno-trapping-math"]
        link_args = []
        if os.environ.get("CGBOUND_SANITIZE"):
            san = ["-fsanitize=address,undefined", "-fno-omit-frame-pointer", "-fno-sanitize-recover=undefined"]
            compile_args = ["-std=c11", "-O1", "-g"] + san
            link_args += san
        if not os.environ.get("CGBOUND_NO_OPENMP") and compiler_accepts(["-fopenmp"]):
            compile_args.append("-fopenmp")
            link_args.append("-fopenmp")
            print("cgbound: building with OpenMP", file=sys.stderr)
        else:
            print("cgbound: building without OpenMP (serial core)", file=sys.stderr)
        for ext in self.extensions:
            ext.extra_compile_args = compile_args
            ext.extra_link_args = link_args
        super().build_extensions()


setup(
    ext_modules=[
        Extension(
            "cgbound._core",
            sources=SOURCES,
            include_dirs=["csrc", numpy.get_include()],
            depends=sorted(os.path.relpath(p, HERE) for p in glob.glob(os.path.join(HERE, "csrc", "*.h"))),
        )
    ],
    cmdclass={"build_ext": BuildExt},
)
