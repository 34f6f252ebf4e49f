# Mesh validation and repair (docs/validation.md). CGAL stays in one private
# translation unit; the public headers expose plain structs and nlohmann::json.
target_sources(fabrica_io PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/src/validate.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/validate_detail.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/repair.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/prepare.cpp)
target_link_libraries(fabrica_io PUBLIC nlohmann_json::nlohmann_json)
if(FABRICA_HAVE_CGAL)
  target_sources(fabrica_io PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/self_intersections_cgal.cpp)
  target_link_libraries(fabrica_io PRIVATE CGAL::CGAL)
endif()
