/* A FollowJointTrajectory action server on rcl_action alone (what rclcpp_action's server, and so ros2_controllers'
   JTC, wraps), with rcl_action's default options (the services' QoS depth 10) or another DEPTH, taking goal requests
   in a wait-set loop as an executor does and answering each at once (rejected): how many requests of a burst a
   native server takes. Built and run by benchmarks/ros2_goal_burst.py; prints "taken N" when SIGINT stops it. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>

#include <control_msgs/action/follow_joint_trajectory.h>
#include <rcl/rcl.h>
#include <rcutils/error_handling.h>
#include <rcl_action/rcl_action.h>

static volatile sig_atomic_t stop = 0;
static void on_signal(int s) { (void)s; stop = 1; }

#define CHECK(call) do { rcl_ret_t r = (call); if (r != RCL_RET_OK) { \
  fprintf(stderr, "%s failed: %s\n", #call, rcutils_get_error_string().str); return 1; } } while (0)

int main(int argc, char ** argv)
{
  if (argc < 2) { fprintf(stderr, "usage: server DEPTH\n"); return 2; }
  int depth = atoi(argv[1]);
  signal(SIGINT, on_signal);
  signal(SIGTERM, on_signal);
  rcl_allocator_t allocator = rcl_get_default_allocator();
  rcl_init_options_t init_options = rcl_get_zero_initialized_init_options();
  CHECK(rcl_init_options_init(&init_options, allocator));
  rcl_context_t context = rcl_get_zero_initialized_context();
  CHECK(rcl_init(0, NULL, &init_options, &context));
  rcl_node_t node = rcl_get_zero_initialized_node();
  rcl_node_options_t node_options = rcl_node_get_default_options();
  CHECK(rcl_node_init(&node, "native_action_server", "", &context, &node_options));
  rcl_clock_t clock;
  CHECK(rcl_clock_init(RCL_STEADY_TIME, &clock, &allocator));
  rcl_action_server_t server = rcl_action_get_zero_initialized_server();
  rcl_action_server_options_t options = rcl_action_server_get_default_options();
  if (depth > 0) {
    options.goal_service_qos.depth = depth;
    options.cancel_service_qos.depth = depth;
    options.result_service_qos.depth = depth;
  }
  const rosidl_action_type_support_t * support =
    ROSIDL_GET_ACTION_TYPE_SUPPORT(control_msgs, FollowJointTrajectory);
  CHECK(rcl_action_server_init(&server, &node, &clock, support, "right_hand/follow_joint_trajectory", &options));
  size_t subscriptions, guards, timers, clients, services;
  CHECK(rcl_action_server_wait_set_get_num_entities(&server, &subscriptions, &guards, &timers, &clients, &services));
  rcl_wait_set_t wait_set = rcl_get_zero_initialized_wait_set();
  CHECK(rcl_wait_set_init(&wait_set, subscriptions, guards, timers, clients, services, 0, &context, allocator));
  control_msgs__action__FollowJointTrajectory_SendGoal_Request request;
  control_msgs__action__FollowJointTrajectory_SendGoal_Response response;
  control_msgs__action__FollowJointTrajectory_SendGoal_Request__init(&request);
  control_msgs__action__FollowJointTrajectory_SendGoal_Response__init(&response);
  response.accepted = false;
  long taken = 0;
  printf("ready\n");
  fflush(stdout);
  while (!stop) {
    CHECK(rcl_wait_set_clear(&wait_set));
    CHECK(rcl_action_wait_set_add_action_server(&wait_set, &server, NULL));
    rcl_ret_t waited = rcl_wait(&wait_set, RCL_MS_TO_NS(100));
    if (waited == RCL_RET_TIMEOUT) { continue; }
    bool goal, cancel, result, expired;
    CHECK(rcl_action_server_wait_set_get_entities_ready(&wait_set, &server, &goal, &cancel, &result, &expired));
    if (!goal) { continue; }
    rmw_request_id_t header;
    while (rcl_action_take_goal_request(&server, &header, &request) == RCL_RET_OK) {
      ++taken;
      CHECK(rcl_action_send_goal_response(&server, &header, &response));
    }
    rcutils_reset_error();
  }
  printf("taken %ld\n", taken);
  fflush(stdout);
  return 0;
}
