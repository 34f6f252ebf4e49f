# The GLSL files embedded into fabrica_render (explicit list).
set(FABRICA_SHADER_FILES
  common.glsl shading.glsl apparent_ridges.glsl
  cutaway.glsl cutaway_seed.frag cutaway_far.vert cutaway_jfa.frag
  mesh.vert mesh.frag mesh_oit.frag depth.frag fullscreen.vert oit_composite.frag
  lines.vert lines.frag
  ar_stage1.vert ar_stage1.frag ar_occluder.frag ar_stage2.frag ar_mask.frag
  ar_bare.vert ar_bare_stage1.frag ar_bare_stage2.frag
  lic_noise.glsl lic_stage1.vert lic_stage1.frag lic_mask.frag lic_stage2.frag)
list(TRANSFORM FABRICA_SHADER_FILES PREPEND ${CMAKE_CURRENT_LIST_DIR}/)
