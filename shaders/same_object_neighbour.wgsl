// same_object_neighbour.wgsl — mirrors backends/src/kernels/neighbourhood_others.rs
// `same_object_neighbours`: the index of neighbour (dx, dy) of pixel `xy` (index `i`), or -1 where it
// is the pixel itself, outside the image or on another object (position w). Included by the kernels
// that bind `position` and read a 3×3 neighbourhood (neighbourhood_others.wgsl, indirect_nearest.wgsl).
fn same_object_neighbour(i: u32, xy: vec2<i32>, dx: i32, dy: i32) -> i32 {
    let n = xy + vec2<i32>(dx, dy);
    if ((dx == 0 && dy == 0) || n.x < 0 || n.y < 0 || n.x >= i32(frame.width) || n.y >= i32(frame.height)) {
        return -1;
    }
    let j = index_at(n.x, n.y);
    if (position_at(j).w != position_at(i).w) {
        return -1;
    }
    return i32(j);
}
