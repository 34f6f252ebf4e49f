# Embeds the web export's files (index.html, study.js) into the program as
# raw string literals: cmake -DOUTPUT=... -DINDEX=... -DSCRIPT=... -P embed_web.cmake
file(READ ${INDEX} index)
file(READ ${SCRIPT} script)
file(WRITE ${OUTPUT} "// Generated from apps/study/web by embed_web.cmake; do not edit.\n"
  "namespace fabrica::study {\n"
  "extern const char* const kWebIndex;\nextern const char* const kWebScript;\n"
  "const char* const kWebIndex = R\"FSWEB(${index})FSWEB\";\n"
  "const char* const kWebScript = R\"FSWEB(${script})FSWEB\";\n"
  "}  // namespace fabrica::study\n")
