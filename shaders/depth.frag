// Depth only (cut context dropped: cutaway.glsl).
void main() { cutaway_discard(); }
