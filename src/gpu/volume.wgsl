// The volume descriptor's ball counts: `lanes` invocations per candidate
// (a power of two up to 64) share the runs of its ball's phase and sum the
// solid voxels in them, by popcounts on the bit grid (level 0) or as
// differences of a pyramid level's running sums along x (above), clipped
// to the grid as on the CPU; the workgroup then adds each candidate's
// lanes. One lane suits many candidates; a late layer's few candidates
// would leave a GPU nearly idle, each lane walking hundreds of runs, so
// the host gives them more lanes. Integers: the same counts as the CPU's.

struct Params {
    // Cells of the grid read (voxels, or blocks of the level).
    dims: vec4<u32>,
    // Level 0: u32 words between rows of the bit grid; above: entries
    // between rows of running sums.
    row_stride: u32,
    level: u32,
    count: u32,
    // Workgroups along x (the workgroup is y * this + x).
    groups_x: u32,
    // Invocations per candidate: 1, 2, 4, ..., 64.
    lanes: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
// Level 0: the bit grid's u64 words as pairs of u32; above: running sums,
// each row starting with 0.
@group(0) @binding(1) var<storage, read> cells: array<u32>;
@group(0) @binding(2) var<storage, read> voxels: array<vec4<i32>>;
// (dy, dz, x0, x1) per run, phase after phase.
@group(0) @binding(3) var<storage, read> runs: array<vec4<i32>>;
@group(0) @binding(4) var<storage, read> phase_starts: array<u32>;
@group(0) @binding(5) var<storage, read_write> counts: array<u32>;

// Set bits lo..=hi of the bit-grid row starting at word `row`.
fn row_bits(row: u32, lo: u32, hi: u32) -> u32 {
    let wl = row + (lo >> 5u);
    let wh = row + (hi >> 5u);
    let lo_mask = 0xffffffffu << (lo & 31u);
    let hi_mask = 0xffffffffu >> (31u - (hi & 31u));
    if (wl == wh) {
        return countOneBits(cells[wl] & lo_mask & hi_mask);
    }
    var n = countOneBits(cells[wl] & lo_mask) + countOneBits(cells[wh] & hi_mask);
    for (var w = wl + 1u; w < wh; w++) {
        n += countOneBits(cells[w]);
    }
    return n;
}

const WORKGROUP: u32 = 64u;

// Each invocation's share of its candidate's count, added up in place.
var<workgroup> partial: array<u32, WORKGROUP>;

@compute @workgroup_size(WORKGROUP)
fn main(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let lanes = params.lanes;
    let lane = local % lanes;
    let i = (group.y * params.groups_x + group.x) * (WORKGROUP / lanes) + local / lanes;
    // No early return: every invocation reaches the barriers below.
    var total = 0u;
    if (i < params.count) {
        total = lane_count(i, lane, lanes);
    }
    partial[local] = total;
    workgroupBarrier();
    for (var step = lanes / 2u; step > 0u; step /= 2u) {
        if (lane < step) {
            partial[local] += partial[local + step];
        }
        workgroupBarrier();
    }
    if (lane == 0u && i < params.count) {
        counts[i] = partial[local];
    }
}

// Solid voxels in runs lane, lane + lanes, ... of candidate i's ball.
fn lane_count(i: u32, lane: u32, lanes: u32) -> u32 {
    let v = voxels[i].xyz;
    var c = v;
    var phase = 0u;
    if (params.level > 0u) {
        let s = 1 << params.level;
        let p = vec3<u32>(v & vec3<i32>(s - 1));
        c = v >> vec3<u32>(params.level);
        phase = p.x + u32(s) * (p.y + u32(s) * p.z);
    }
    let d = vec3<i32>(params.dims.xyz);
    var total = 0u;
    for (var k = phase_starts[phase] + lane; k < phase_starts[phase + 1u]; k += lanes) {
        let run = runs[k];
        let y = c.y + run.x;
        let z = c.z + run.y;
        if (y < 0 || z < 0 || y >= d.y || z >= d.z) {
            continue;
        }
        let x0 = max(c.x + run.z, 0);
        let x1 = min(c.x + run.w, d.x - 1);
        if (x0 > x1) {
            continue;
        }
        let row = (u32(z) * params.dims.y + u32(y)) * params.row_stride;
        if (params.level == 0u) {
            total += row_bits(row, u32(x0), u32(x1));
        } else {
            total += cells[row + u32(x1) + 1u] - cells[row + u32(x0)];
        }
    }
    return total;
}
