// The package's own messages, included for code that also sees the core.
//
// catkin generates message classes in the package's namespace, so the messages SafetyMap.msg and
// StageTimings.msg become stereo_safety_map::SafetyMap and stereo_safety_map::StageTimings: the
// same names as the core's result structs (core/safety_map.h, core/safety_mapper.h). A
// translation unit that includes both fails to compile. Include the messages through this header
// only: it renames the two message typedefs to SafetyMapMsg and StageTimingsMsg (the templates
// SafetyMap_<A> / StageTimings_<A>, the Ptr / ConstPtr typedefs, the message traits and the type
// strings "stereo_safety_map/SafetyMap" are untouched, so the wire types do not change).
#pragma once

#ifdef STEREO_SAFETY_MAP_MESSAGE_SAFETYMAP_H
#error "include stereo_safety_map/ros/msgs.h instead of stereo_safety_map/SafetyMap.h"
#endif
#ifdef STEREO_SAFETY_MAP_MESSAGE_HYBRIDSAFETYMAP_H
#error "include stereo_safety_map/ros/msgs.h instead of stereo_safety_map/HybridSafetyMap.h"
#endif
#ifdef STEREO_SAFETY_MAP_MESSAGE_GATESTATE_H
#error "include stereo_safety_map/ros/msgs.h instead of stereo_safety_map/GateState.h"
#endif

// The messages' own dependencies first, so that the renaming below reaches nothing but the two
// message headers.
#include <geometry_msgs/Point.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/Vector3.h>
#include <nav_msgs/MapMetaData.h>
#include <std_msgs/Header.h>
#include <stereo_safety_map/GroundSegment.h>
#include <stereo_safety_map/SaveMap.h>

#define SafetyMap SafetyMapMsg
#define StageTimings StageTimingsMsg
#include <stereo_safety_map/SafetyMap.h>
#include <stereo_safety_map/StageTimings.h>
#undef SafetyMap
#undef StageTimings
// HybridSafetyMap.msg (paper 001's hybrid map) likewise meets core/hybrid_safety_map.h's
// HybridSafetyMap: the message is HybridSafetyMapMsg here.
#define HybridSafetyMap HybridSafetyMapMsg
#include <stereo_safety_map/HybridSafetyMap.h>
#undef HybridSafetyMap
// GateState.msg (the safety gate's decision) likewise meets core/safety_gate.h's GateState: the
// message is GateStateMsg here.
#define GateState GateStateMsg
#include <stereo_safety_map/GateState.h>
#undef GateState
