#!/usr/bin/env python3
"""The instructions of a render by phase, from a callgrind profile of `raylume render --threads 1`
(docs/PERFORMANCE.md, "Where a render's time goes").

    valgrind --tool=callgrind --callgrind-out-file=F raylume render SCENE --threads 1 ...
    python3 tools/render_phases.py F [F ...]

Profiles recorded with `--dump-instr=yes` (for a look at the hot instructions) are read as well.

A phase made of whole functions counts their inclusive cost (each call edge's cost as callgrind
records it); the render loop's own functions, whose callees are mostly inlined, count each line of
their self cost by the source file and line it comes from. Lines of the standard library or glam count
with the project line before them in the same function.
"""
import collections
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent / 'crates'


def read(path):
    """Self-cost entries (function, file, line, Ir) in file order and call edges {(caller, callee): Ir}."""
    names = {'fl': {}, 'fn': {}}
    entries, calls = [], collections.Counter()
    fn = fl = fi = cfn = None
    pending = False
    # Position columns: `line`, or `instr line` for a profile recorded with `--dump-instr=yes`; each
    # absolute, relative to the same column of the line before (`+n`, `-n`) or the same (`*`).
    columns, last = 1, [0]

    def ref(kind, rest):
        m = re.match(r'\((\d+)\)(?: (.*))?', rest)
        if not m:
            return rest
        if m.group(2) is not None:
            names[kind][m.group(1)] = m.group(2)
        return names[kind].get(m.group(1), m.group(1))

    for raw in open(path):
        line = raw.rstrip('\n')
        if not line or line[0] == '#':
            continue
        if line.startswith('positions:'):
            columns = len(line.split()) - 1
            last = [0] * columns
            continue
        if line[0].isdigit() or line[0] in '+-*':
            p = line.split()
            for c in range(min(columns, len(p))):
                t = p[c]
                if t != '*':
                    last[c] = last[c] + int(t, 0) if t[0] in '+-' else int(t, 0)
            ln = last[columns - 1]
            cost = int(p[columns]) if len(p) > columns else 0
            if pending:
                calls[(fn, cfn)] += cost
                pending = False
            else:
                entries.append((fn, fi or fl, ln, cost))
            continue
        key, _, rest = line.partition('=')
        if key == 'fl':
            fl, fi = ref('fl', rest), None
        elif key in ('fi', 'fe'):
            fi = ref('fl', rest)
        elif key == 'fn':
            fn, fi = ref('fn', rest), None
        elif key == 'cfn':
            cfn = ref('fn', rest)
        elif key in ('cfl', 'cfi'):
            ref('fl', rest)
        elif key == 'calls':
            pending = True
    return entries, calls


def family(name):
    """A function's name without callgrind's recursion level."""
    return re.sub(r"'\d+$", '', name)


def project_file(path):
    m = re.search(r'/crates/(.*)$', path or '')
    return m.group(1) if m else None


_source = {}


def source(pf, ln):
    if (pf, ln) not in _source:
        try:
            _source[(pf, ln)] = (ROOT / pf).read_text().split('\n')[ln - 1]
        except (OSError, IndexError):
            _source[(pf, ln)] = ''
    return _source[(pf, ln)]


# The lines that build the hit record: the triangle's (TriangleHit::hit, unit_normal, Triangles::hit),
# the sphere's point, normal and error (with curve_depth) and the plane's.
REFINEMENT = [('intersect/src/watertight.rs', 'pub fn hit(&self, tri: &Triangle) -> Hit {', 9),
              ('intersect/src/watertight.rs', 'pub fn unit_normal(tri: &Triangle)', 9),
              ('accel/src/bvh/kernel.rs', 'pub fn hit(&self, (h, leaf, bit)', 4),
              ('intersect/src/shapes.rs', 'pub(crate) fn sphere_hit_at(center: Vec3A', 13),
              ('intersect/src/shapes.rs', 'fn curve_depth(q: Vec3A, radius: f32)', 4),
              ('intersect/src/shapes.rs', 'fn plane_hit(plane: &Plane', 5)]


def refinement_lines():
    ranges = []
    for pf, start, n in REFINEMENT:
        lines = (ROOT / pf).read_text().split('\n')
        first = next(i for i, l in enumerate(lines, 1) if start in l)
        ranges.append((pf, first, first + n))
    return ranges


def loop_function(fn):
    """The render loop's own functions: the integrator and the row and band closures."""
    return ('raylume_integrator::whitted' in fn or 'raylume_integrator::render::' in fn
            or 'FnMut<A> for &F>::call_mut' in fn) and 'Observer' not in fn


def line_phase(fn, pf, ln):
    if pf.startswith('camera/') or pf == 'integrator/src/sampler.rs':
        return 'camera rays'
    if pf == 'integrator/src/render.rs':
        s = source(pf, ln)
        return 'film accumulation' if ('out[i] +=' in s or '*px' in s) else 'camera rays'
    if pf == 'integrator/src/whitted.rs':
        s = source(pf, ln)
        if 'let unoccluded' in ''.join(source(pf, k) for k in range(ln - 12, ln + 1)) and 'stats.shadow' in ''.join(
                source(pf, k) for k in range(ln, ln + 12)):
            return 'shadow rays'
        if any(k in s for k in ('offset_ray_origin', 'Ray::with_time', 'reflect(', 'refract(')):
            return 'spawn'
        return 'shading'
    if pf.startswith('accel/') or pf == 'geometry/src/ray.rs':
        return 'shadow rays' if 'direct' in fn else 'traversal'
    if any(pf == f and a <= ln < b for f, a, b in SPAWN):
        return 'spawn'
    return 'shading'


def span(pf, first, end):
    """The lines of `pf` from the one holding `first` up to the one holding `end`."""
    lines = (ROOT / pf).read_text().split('\n')
    a = next(i for i, l in enumerate(lines, 1) if first in l)
    return pf, a, next(i for i, l in enumerate(lines, 1) if i > a and end in l)


# The functions that make a secondary ray's origin and direction.
SPAWN = [span('geometry/src/lib.rs', 'pub fn offset_ray_origin', 'pub fn spawn_ray_to'),
         span('material/src/optics.rs', 'pub fn reflect(', 'pub fn fresnel_dielectric')]


def callee_phase(callee):
    if 'occluded' in callee:
        return 'shadow rays'
    if 'Bvh<P>::closest' in callee or 'closest_hits' in callee or 'ray_by_ray' in callee:
        return 'traversal'
    if 'offset_ray_origin' in callee:
        return 'spawn'
    if 'Observer' in callee:
        return 'film accumulation'
    return 'shading'


RENDER = ['camera rays', 'traversal', 'refinement', 'shading', 'shadow rays', 'spawn', 'film accumulation']
# Each fixed cost by the functions that may hold it, the first one the profile has: the optimiser
# inlines some into their callers (`Bvh::build` into `Bvh::with_kernel`, `load_cubemap` leaving one
# call of `load_face` per face).
FIXED = {'scene load': ['raylume_scene::p3f::load'],
         'BVH build': ['raylume_accel::bvh::Bvh<P>::build', 'raylume_accel::bvh::Bvh<P>::with_kernel'],
         'cubemap load': ['raylume_render::env::load_cubemap', 'raylume_render::env::load_face'],
         'film write': ['raylume_integrator::film::Film::write']}


def phases(path):
    entries, calls = read(path)
    selfc = collections.Counter()
    for fn, _, _, c in entries:
        selfc[family(fn)] += c
    inclusive = collections.Counter(selfc)
    for (a, b), c in calls.items():
        if family(a) != family(b):
            inclusive[family(a)] += c
    ranges = refinement_lines()

    def refines(pf, ln):
        return any(pf == f and a <= ln <= b for f, a, b in ranges)

    out = collections.Counter()
    refined, context, last = 0, {}, {}
    for fn, f, ln, c in entries:
        pf = project_file(f)
        if pf:
            context[fn] = refines(pf, ln)
        if (pf and refines(pf, ln)) or (not pf and context.get(fn)):
            refined += c
        if not loop_function(fn):
            continue
        if pf:
            last[fn] = 'refinement' if refines(pf, ln) else line_phase(fn, pf, ln)
        out[last.get(fn, 'camera rays')] += c
    for (a, b), c in calls.items():
        if loop_function(a) and not loop_function(b) and 'rayon' not in b:
            out[callee_phase(b)] += c
    # The hit records built inside the walks' callees.
    out['traversal'] -= refined - out['refinement']
    out['refinement'] = refined
    total = sum(selfc.values())
    render = inclusive['raylume_integrator::render::render_pass']
    fixed = {k: next((inclusive[n] for n in names if inclusive[n]), 0) for k, names in FIXED.items()}
    fixed['accumulator'] = sum(v for k, v in inclusive.items() if k.startswith('raylume_integrator::estimate::Accumulator::'))
    fixed['rest of the process'] = total - render - sum(fixed.values())
    return total, render, out, fixed


def main(paths):
    rows = [phases(p) for p in paths]
    print('| phase | ' + ' | '.join(pathlib.Path(p).name for p in paths) + ' |')
    print('|---|' + '---|' * len(paths))
    for k in RENDER:
        print(f'| {k} | ' + ' | '.join(f'{o[k] / 1e6:,.1f} M ({100 * o[k] / r:.1f} %)' for _, r, o, _ in rows) + ' |')
    print('| **render** (`render_pass`) | ' + ' | '.join(f'**{r / 1e6:,.1f} M**' for _, r, _, _ in rows) + ' |')
    for k in list(FIXED) + ['accumulator', 'rest of the process']:
        print(f'| {k} | ' + ' | '.join(f'{fx[k] / 1e6:,.1f} M ({100 * fx[k] / t:.1f} % of all)' for t, _, _, fx in rows) + ' |')
    print('| **process** | ' + ' | '.join(f'**{t / 1e6:,.1f} M**' for t, _, _, _ in rows) + ' |')


if __name__ == '__main__':
    main(sys.argv[1:])
