// Depth only (cut context dropped: cutaway.glsl). NO_CUT: for structures no
// cutaway touches, an empty shader (depth tested and written before it).
void main() {
#ifndef NO_CUT
  cutaway_discard();
#endif
}
