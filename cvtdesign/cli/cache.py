"""`cvtdesign cache`: where the compiled-model cache is and how big (core.native), and `--clear` to empty it."""
from __future__ import annotations

from cvtdesign.core import native


def run(args):
    folder = native.cache_dir()
    if args.clear:
        libraries, size = native.clear_cache()
        print(f"removed {libraries} compiled models ({size / 2**20:.1f} MB) from {folder}")
        return 0
    s = native.cache_summary()
    print(f"compiled-model cache: {folder} (set CVTDESIGN_CACHE to move it)")
    print(f"{s['libraries']} compiled models, {s['bytes'] / 2**20:.1f} MB; at most {s['limit'] / 2**20:.0f} MB are "
          "kept (the models used longest ago go first); `cvtdesign cache --clear` empties it")
    return 0
