"""`cvtdesign cache`: where the compiled-model cache is and how big (core.native), and `--clear` to empty it."""
from __future__ import annotations

from cvtdesign.core import native
from cvtdesign.io.output import OutputError


def run(args):
    folder = native.cache_dir()
    if args.clear:
        libraries, size, failed = native.clear_cache()
        removed = f"removed {libraries} compiled models ({size / 2**20:.1f} MB) from {folder}"
        if failed:       # what it did and what it could not, in one line, exit status 2
            models = sum(p.suffix == ".so" for p, _ in failed)
            raise OutputError(f"cache --clear: {removed}; could not remove {len(failed)} files ({models} compiled "
                              f"models), {failed[0][0].name} first: {failed[0][1]}; expected a cache folder this "
                              "user may change (set CVTDESIGN_CACHE to use another)")
        print(removed)
        return 0
    s = native.cache_summary()
    print(f"compiled-model cache: {folder} (set CVTDESIGN_CACHE to move it)")
    print(f"{s['libraries']} compiled models, {s['bytes'] / 2**20:.1f} MB; at most {s['limit'] / 2**20:.0f} MB are "
          "kept (the models used longest ago go first); `cvtdesign cache --clear` empties it")
    return 0
