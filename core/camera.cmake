# Camera, projection (Projector) and the CPU depth rasteriser shared by lines/
# and hatching/.
target_sources(fabrica_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/camera.cpp
                                    ${CMAKE_CURRENT_LIST_DIR}/src/depth_raster.cpp)
target_link_libraries(fabrica_core PUBLIC nlohmann_json::nlohmann_json)
